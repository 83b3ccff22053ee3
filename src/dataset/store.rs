//! A dataset's folder: the definition, each episode's files, written under temporary names
//! and renamed when complete, and the shards' manifests.

use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::{self, Write};
use std::path::{Path, PathBuf};

/// The definition every worker of a dataset must share: written by the first, compared by
/// the others, so that a folder never mixes episodes of two datasets.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Definition {
    /// The dataset's seed.
    pub seed: u64,
    /// Episodes in the whole dataset (all shards).
    pub episodes: u64,
    /// `--seconds`, when episodes are cut short.
    pub seconds: Option<f64>,
    /// The scene file's text.
    pub scene: String,
    /// The variation file's text.
    pub vary: String,
}

/// What an episode measured: the outcomes of the headless summary.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Outcomes {
    /// The largest rise of the tissue's highest particle above its start, m.
    pub lift_m: f64,
    /// Rise of the tissue's centre of mass from start to end, m.
    pub com_rise_m: f64,
    /// Tissue pieces at the end.
    pub pieces: usize,
    /// The wound gap at the end, m, in a scene with a `wound` (see
    /// [`crate::world::wound`]); absent otherwise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub wound_gap_m: Option<f64>,
    /// Each tool's peak contact force, N.
    pub peak_force_n: BTreeMap<String, f64>,
    /// The guard event that stopped the episode, if one did.
    pub guard_stop: Option<String>,
}

/// One episode as the manifest lists it: everything that is the same on every machine.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Episode {
    /// Index in the dataset, from 0.
    pub index: u64,
    /// The dataset's seed (the episode's draws come from the seed and the index).
    pub seed: u64,
    /// Draws of the parameters it took to get a valid scene.
    pub draws: u32,
    /// Each varied value's path and the value the scene got.
    pub params: BTreeMap<String, toml::Value>,
    /// What happened.
    pub outcomes: Outcomes,
    /// Frames stepped.
    pub frames: u32,
    /// Simulated seconds.
    pub simulated_s: f64,
    /// Substeps in all.
    pub substeps: u64,
    /// The bag's file name in the dataset folder.
    pub bag: String,
    /// Messages in the bag.
    pub bag_messages: u64,
    /// The sampled scene's file name (a scene file: `run --headless --scene` reruns it).
    pub scene: String,
}

/// An episode's record file: the manifest's line and what varies between runs of it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// The episode.
    #[serde(flatten)]
    pub episode: Episode,
    /// Wall time of the episode (sampling, simulating, recording, writing), s.
    pub wall_s: f64,
    /// Wall time of the headless run inside it (building the world, stepping, finishing
    /// the bag), s: `wall_s` less this is the dataset machinery's cost.
    pub simulate_s: f64,
    /// Rayon threads the episode's solver ran on.
    pub threads: usize,
}

/// An episode's file name: `episode-000042.EXT`.
pub fn episode_file(index: u64, ext: &str) -> String {
    format!("episode-{index:06}.{ext}")
}

/// A temporary name beside `name`, unique to this process on this host: hidden, and ending
/// in `.partial`, so nothing reads it as an episode's file. Two workers that run the same
/// episode at once (a retried index) never write one file.
pub fn partial_name(name: &str) -> String {
    format!(".{name}.{}-{}.partial", host(), std::process::id())
}

/// Whether a file name is a temporary one ([`partial_name`]).
pub fn is_partial(name: &str) -> bool {
    name.starts_with('.') && name.ends_with(".partial")
}

fn host() -> String {
    let mut buf = [0u8; 256];
    // SAFETY: the buffer is valid for its length; gethostname writes at most that many bytes.
    let ok = unsafe { libc::gethostname(buf.as_mut_ptr().cast(), buf.len()) } == 0;
    let end = buf.iter().position(|&b| b == 0).unwrap_or(buf.len());
    let name: String = String::from_utf8_lossy(&buf[..end])
        .chars()
        .filter(|c| c.is_ascii_alphanumeric() || *c == '-')
        .collect();
    if ok && !name.is_empty() {
        name
    } else {
        "host".into()
    }
}

/// Syncs the file at `path` and renames it to `to` in the same folder, then syncs the
/// folder, so that `to` appears complete or not at all.
pub fn commit(path: &Path, to: &Path) -> io::Result<()> {
    File::open(path)?.sync_all()?;
    std::fs::rename(path, to)?;
    if let Some(dir) = to.parent() {
        // A folder opened for reading can be synced on Linux; elsewhere this may fail
        // harmlessly.
        let _ = File::open(if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        })
        .and_then(|d| d.sync_all());
    }
    Ok(())
}

/// Writes `bytes` to `dir/name` atomically (a temporary name, synced, renamed).
pub fn write_atomic(dir: &Path, name: &str, bytes: &[u8]) -> io::Result<()> {
    let partial = dir.join(partial_name(name));
    let mut file = OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&partial)?;
    file.write_all(bytes)?;
    drop(file);
    commit(&partial, &dir.join(name)).inspect_err(|_| {
        let _ = std::fs::remove_file(&partial);
    })
}

/// The episode's record, when the episode is complete (its record and bag are there).
pub fn finished(dir: &Path, index: u64) -> Option<Record> {
    let text = std::fs::read_to_string(dir.join(episode_file(index, "json"))).ok()?;
    let record: Record = serde_json::from_str(&text).ok()?;
    dir.join(&record.episode.bag).is_file().then_some(record)
}

/// A shard's manifest file name: `manifest-2-of-8.jsonl`.
pub fn manifest_file(shard: super::Shard) -> String {
    format!("manifest-{}-of-{}.jsonl", shard.index, shard.count)
}

/// One manifest line (no newline).
pub fn manifest_line(episode: &Episode) -> String {
    serde_json::to_string(episode).expect("an episode is always JSON")
}

/// Writes a shard's manifest anew from its finished episodes, in index order.
pub fn rewrite_manifest(dir: &Path, shard: super::Shard, episodes: &[Episode]) -> io::Result<()> {
    let mut text = String::new();
    for e in episodes {
        text.push_str(&manifest_line(e));
        text.push('\n');
    }
    write_atomic(dir, &manifest_file(shard), text.as_bytes())
}

/// Appends one episode to a shard's manifest (one worker per shard writes it).
pub fn append_manifest(dir: &Path, shard: super::Shard, episode: &Episode) -> io::Result<()> {
    let mut file = OpenOptions::new()
        .append(true)
        .create(true)
        .open(dir.join(manifest_file(shard)))?;
    file.write_all(format!("{}\n", manifest_line(episode)).as_bytes())?;
    file.sync_data()
}

/// Every episode the folder's manifests list, once each, in index order; with the problems
/// met (a line cut short by a killed worker, two different lines for one index).
pub fn read_manifests(dir: &Path) -> io::Result<(Vec<Episode>, Vec<String>)> {
    let mut names: Vec<PathBuf> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| {
            p.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("manifest-") && n.ends_with(".jsonl"))
        })
        .collect();
    names.sort();
    let mut episodes: BTreeMap<u64, Episode> = BTreeMap::new();
    let mut problems = Vec::new();
    for path in names {
        let text = std::fs::read_to_string(&path)?;
        for (n, line) in text.lines().enumerate() {
            if line.trim().is_empty() {
                continue;
            }
            match serde_json::from_str::<Episode>(line) {
                Ok(e) => match episodes.get(&e.index) {
                    Some(seen) if *seen != e => problems.push(format!(
                        "{}:{}: episode {} listed twice with different contents",
                        path.display(),
                        n + 1,
                        e.index
                    )),
                    _ => {
                        episodes.insert(e.index, e);
                    }
                },
                Err(why) => problems.push(format!(
                    "{}:{}: not a manifest line ({why})",
                    path.display(),
                    n + 1
                )),
            }
        }
    }
    Ok((episodes.into_values().collect(), problems))
}
