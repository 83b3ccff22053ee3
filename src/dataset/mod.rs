//! Datasets: many headless episodes of one scene with its keys varied, each recorded to its
//! own bag and labelled with what happened, reproducible and split across machines.
//!
//! `dvrk-tissue-sim dataset --scene FILE --vary VARY.toml --episodes N --out DIR` runs
//! episodes 0..N. Episode `i` draws its scene from the variation file ([`vary`]) with a
//! random stream fixed by the dataset's seed and `i` alone ([`episode_rng`]), checks it as a
//! scene file is checked, and runs it as `run --headless --record` does (the same loop and
//! recorder, waiting for the writer rather than dropping a frame). Its files in `DIR`:
//!
//! - `episode-000042.mcap`: the bag (the node's topics at the scene's rates);
//! - `episode-000042.toml`: the sampled scene, a scene file (`run --headless --scene` reruns
//!   the episode);
//! - `episode-000042.json`: the record ([`store::Record`]): the drawn parameters, the seed,
//!   the outcomes (lift, centre-of-mass rise, pieces, the wound gap at the end in a scene
//!   with a `wound`, peak force per tool, the guard stop if any), frames, substeps, wall
//!   time;
//! - `manifest-I-of-N.jsonl`: one line per finished episode of shard I ([`store::Episode`]:
//!   the record less its wall time and thread count, so a line is the same wherever the
//!   episode ran); `dataset summary DIR` reads every shard's manifest;
//! - `dataset.json`: the definition ([`store::Definition`]: seed, episode count, `--seconds`,
//!   the scene and variation texts); a worker with another definition is refused.
//!
//! **Why JSON Lines**: a manifest is appended one line per finished episode, so a killed
//! worker loses at most a line (a reader skips a line cut short, and the next run of the
//! shard writes it again), and it is read as is by pandas (`read_json(lines=True)`), DuckDB
//! and Hugging Face `datasets`. Parquet would need the arrow stack as a dependency and is
//! written a whole row group at a time.
//!
//! **Deterministic**: the draws for episode `i` come from ChaCha8 seeded with the dataset's
//! seed, on stream `i` ([`episode_rng`]): a counter-based generator with a published
//! specification, the same on every platform, and independent of which shard or job runs
//! the episode or in which order. On the CPU backend the simulation is deterministic too:
//! the same episode gives a bag identical to the bit (tests/dataset.rs compares them).
//!
//! **Resumable**: each file is written under a hidden temporary name unique to its process
//! ([`store::partial_name`]), synced and renamed into place; the record is renamed last, so
//! an episode with a record is complete and a rerun skips it. A worker killed mid-episode
//! leaves only a `.partial` file (never read; `dataset summary` counts them). At start a
//! worker rewrites its shard's manifest from the records, so a line lost to a kill between
//! the record and the manifest comes back.
//!
//! **Sharding**: shard `i` of `N` runs the episodes whose index is `i` modulo `N`
//! ([`Shard`]): `--shard i/N`, else Slurm's `SLURM_ARRAY_TASK_ID` (less
//! `SLURM_ARRAY_TASK_MIN`) of `SLURM_ARRAY_TASK_COUNT`, else a Kubernetes Indexed Job's
//! `JOB_COMPLETION_INDEX` of `JOB_COMPLETIONS` (Kubernetes sets the index only: the Job
//! sets `JOB_COMPLETIONS` to its `completions`), else one shard. Each shard has its own
//! manifest: appending to one shared file from many machines is not safe on NFS.
//!
//! **Jobs**: `--jobs J` runs J episodes at once on one machine, each on its own rayon pool
//! of ⌊cores / J⌋ threads (at least one), so J episodes together use the cores one episode
//! would. An episode's result does not depend on J: the CPU solver's block-coloured P2G and
//! its sums do not depend on the thread count (tests/dataset.rs compares bags of episodes
//! run on one thread and on two). On the GPU backend each episode creates its device as any
//! run does; the device is then the bottleneck, so run one job per GPU (`--jobs 1`, one GPU
//! per Slurm task or pod).
//!
//! The sampled scene files name a blade mesh as the original scene does, relative to that
//! scene's folder: rerunning such an episode from its scene file needs the mesh beside it.

pub mod store;
pub mod vary;

use rand::rngs::ChaCha8Rng;
use rand::SeedableRng;

/// The random stream of episode `index` of a dataset with `seed`: ChaCha8 keyed by the seed,
/// on stream `index`.
pub fn episode_rng(seed: u64, index: u64) -> ChaCha8Rng {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    rng.set_stream(index);
    rng
}

/// Which episodes a worker runs: those whose index is `index` modulo `count`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// This worker's shard, from 0.
    pub index: u64,
    /// Shards in all.
    pub count: u64,
}

impl Shard {
    /// The whole dataset in one shard.
    pub const ALL: Shard = Shard { index: 0, count: 1 };

    /// Shard `index` of `count`; refused unless `index < count`.
    pub fn new(index: u64, count: u64) -> Result<Shard, String> {
        if count == 0 || index >= count {
            Err(format!(
                "shard {index} of {count}: the index must be below the count (shards are \
                 numbered from 0)"
            ))
        } else {
            Ok(Shard { index, count })
        }
    }

    /// Parses `i/N`.
    pub fn parse(text: &str) -> Result<Shard, String> {
        let bad = || format!("--shard {text:?}: expected i/N, e.g. 0/4 (shards numbered from 0)");
        let (i, n) = text.split_once('/').ok_or_else(bad)?;
        let i = i.trim().parse().map_err(|_| bad())?;
        let n = n.trim().parse().map_err(|_| bad())?;
        Shard::new(i, n).map_err(|e| format!("--shard {text:?}: {e}"))
    }

    /// The shard a scheduler gave this process through its environment (`var` looks a name
    /// up): a Slurm job array task, else a Kubernetes Indexed Job's pod; `None` when neither
    /// is set. Where it comes from is returned for the log.
    pub fn from_env(
        var: impl Fn(&str) -> Option<String>,
    ) -> Result<Option<(Shard, &'static str)>, String> {
        let number = |name: &str| -> Result<Option<u64>, String> {
            match var(name) {
                None => Ok(None),
                Some(v) => v
                    .trim()
                    .parse()
                    .map(Some)
                    .map_err(|_| format!("{name}={v:?}: not a whole number")),
            }
        };
        if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
            let count = number("SLURM_ARRAY_TASK_COUNT")?
                .ok_or("SLURM_ARRAY_TASK_ID is set but SLURM_ARRAY_TASK_COUNT is not".to_owned())?;
            let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(0);
            let index = id.checked_sub(min).ok_or(format!(
                "SLURM_ARRAY_TASK_ID {id} is below SLURM_ARRAY_TASK_MIN {min}"
            ))?;
            return Shard::new(index, count)
                .map(|s| Some((s, "SLURM_ARRAY_TASK_ID/SLURM_ARRAY_TASK_COUNT")))
                .map_err(|e| {
                    format!("{e} (an array with a step, e.g. --array=0-9:2, cannot shard)")
                });
        }
        if let Some(index) = number("JOB_COMPLETION_INDEX")? {
            let count = number("JOB_COMPLETIONS")?.ok_or(
                "JOB_COMPLETION_INDEX is set but JOB_COMPLETIONS (the Job's completions, set in \
                 its manifest) is not"
                    .to_owned(),
            )?;
            return Shard::new(index, count)
                .map(|s| Some((s, "JOB_COMPLETION_INDEX/JOB_COMPLETIONS")));
        }
        Ok(None)
    }

    /// The indices of `episodes` this shard runs, in order.
    pub fn indices(self, episodes: u64) -> impl Iterator<Item = u64> {
        (self.index..episodes).step_by(self.count as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    #[test]
    fn shards_partition_the_episodes() {
        let mut all: Vec<u64> = (0..3)
            .flat_map(|i| Shard::new(i, 3).unwrap().indices(10))
            .collect();
        all.sort();
        assert_eq!(all, (0..10).collect::<Vec<_>>());
        assert!(Shard::parse("3/3").is_err());
        assert!(Shard::parse("1-3").is_err());
        assert_eq!(Shard::parse("1/3"), Ok(Shard { index: 1, count: 3 }));
    }

    #[test]
    fn shard_from_the_schedulers_environment() {
        let env = |pairs: &'static [(&'static str, &'static str)]| {
            move |name: &str| {
                pairs
                    .iter()
                    .find(|(k, _)| *k == name)
                    .map(|(_, v)| v.to_string())
            }
        };
        let slurm = Shard::from_env(env(&[
            ("SLURM_ARRAY_TASK_ID", "4"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ]));
        assert_eq!(slurm.unwrap().unwrap().0, Shard { index: 3, count: 8 });
        let k8s = Shard::from_env(env(&[
            ("JOB_COMPLETION_INDEX", "2"),
            ("JOB_COMPLETIONS", "5"),
        ]));
        assert_eq!(k8s.unwrap().unwrap().0, Shard { index: 2, count: 5 });
        assert!(Shard::from_env(env(&[("JOB_COMPLETION_INDEX", "2")])).is_err());
        assert_eq!(Shard::from_env(env(&[])), Ok(None));
    }

    #[test]
    fn an_episodes_stream_depends_on_the_seed_and_index_only() {
        let a = episode_rng(7, 3).next_u64();
        assert_eq!(a, episode_rng(7, 3).next_u64());
        assert_ne!(a, episode_rng(7, 4).next_u64());
        assert_ne!(a, episode_rng(8, 3).next_u64());
    }
}
