//! Variation files: which scene keys a dataset varies and how, and the sampled scenes.
//!
//! A variation file is TOML with one `[[vary]]` table per varied key:
//!
//! ```toml
//! redraws = 100                                  # optional (default 100)
//!
//! [[vary]]
//! key = "tissue.0.material.youngs_modulus"       # a scene key, addressed by its path
//! dist = "log_uniform"
//! min = 3000.0
//! max = 12000.0
//!
//! [[vary]]
//! key = "tool.0.keyframe.*.position"             # `*`: every element of an array
//! add = true                                     # a perturbation of the file's value
//! dist = "normal"
//! mean = 0.0
//! std = 0.001
//! min = -0.002
//! max = 0.002
//! ```
//!
//! | key | meaning |
//! |---|---|
//! | `key` | the scene key's path as the scene file spells it: table and key names joined by `.`, a `[[table]]`'s entries by their index from 0 (`tissue.0`, `tool.1.keyframe.3.t`), `*` for every entry of an array. A key that is an array of numbers (`position`, `center`, `size`, `rpy_deg`, `origin`) is varied element by element, each with its own draw; `.2` picks one element (`tissue.0.center.2`). Keys with a default may be named though the scene file leaves them out (`tissue.0.material.toughness`). |
//! | `dist` | `uniform` (`min`, `max`), `log_uniform` (`min`, `max`, both > 0), `normal` (`mean`, `std`, and the bounds `min`, `max`: a draw outside them is drawn again) or `choice` (`values`: a list of TOML values, any type the key takes, drawn with equal odds) |
//! | `shared` | `true`: one draw for every value the key reaches (`tool.0.keyframe.*.position.0` with `add`: the whole path shifted along x); default `false`: a draw each |
//! | `add` | `true`: the draw is added to the scene's value (a perturbation: keyframe positions and times, a tissue's centre); default `false`: the draw replaces it. Not with `choice`. |
//! | `redraws` | (top level) how many times an episode's parameters are drawn before the episode is refused, when a combination of draws fails the scene's validation (keyframe times out of order, a tissue leaving the domain) |
//!
//! Integer keys (`particles_per_axis`, `max_substeps_per_frame`) take the draw rounded to
//! the nearest integer. Every sampled scene is checked as `check` checks a scene file (its
//! keys by [`crate::config::from_str`], its arms against their URDFs' joint limits by
//! [`crate::sim::check_arm_urdfs`]): an invalid draw is never simulated. The endoscope's
//! view varies through the ECM's `home_joints` (the camera rides at its tip).
//!
//! The file is refused on load, naming the entry, its key, the value and the reason, when an
//! entry has an unknown field or distribution, a key the scene does not have, an empty range
//! (`min` ≥ `max`), a bound a distribution cannot honour (`log_uniform` with `min` ≤ 0,
//! `std` ≤ 0), or a distribution that reaches outside the key's valid range: each bound (each
//! `choice` value) is applied alone to the scene and must pass its validation, so
//! `poisson_ratio` uniform on 0.3–0.6 is refused for ν ≥ 0.5 rather than redrawn.

use crate::config::{self, Scene};
use rand::Rng;
use serde::Deserialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use toml::Value;

/// Draws of one episode before it is refused, unless the file's `redraws` says otherwise.
pub const DEFAULT_REDRAWS: u32 = 100;

/// One `[[vary]]` entry as written.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct EntryFile {
    key: String,
    dist: String,
    #[serde(default)]
    add: bool,
    #[serde(default)]
    shared: bool,
    min: Option<f64>,
    max: Option<f64>,
    mean: Option<f64>,
    std: Option<f64>,
    values: Option<Vec<Value>>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct VaryFile {
    redraws: Option<u32>,
    #[serde(default)]
    vary: Vec<EntryFile>,
}

/// A distribution of one key's values.
#[derive(Clone, Debug, PartialEq)]
pub enum Distribution {
    /// Uniform on [min, max).
    Uniform {
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
    /// Uniform in the logarithm on [min, max): every factor of 10 equally likely.
    LogUniform {
        /// Lower bound (> 0).
        min: f64,
        /// Upper bound.
        max: f64,
    },
    /// Normal, truncated to [min, max] by drawing again.
    Normal {
        /// Mean.
        mean: f64,
        /// Standard deviation (> 0).
        std: f64,
        /// Lower bound.
        min: f64,
        /// Upper bound.
        max: f64,
    },
    /// One of the values, each equally likely.
    Choice(Vec<Value>),
}

impl Distribution {
    /// One draw.
    fn sample(&self, rng: &mut impl Rng) -> Value {
        match self {
            Distribution::Uniform { min, max } => Value::Float(min + (max - min) * unit(rng)),
            Distribution::LogUniform { min, max } => {
                Value::Float((min.ln() + (max.ln() - min.ln()) * unit(rng)).exp())
            }
            Distribution::Normal {
                mean,
                std,
                min,
                max,
            } => loop {
                // Box–Muller: two uniform draws per normal one, the second value unused, so
                // each draw takes the same number of words from the stream.
                let u1 = 1.0 - unit(rng);
                let u2 = unit(rng);
                let z = (-2.0 * u1.ln()).sqrt() * (std::f64::consts::TAU * u2).cos();
                let x = mean + std * z;
                if (*min..=*max).contains(&x) {
                    break Value::Float(x);
                }
            },
            Distribution::Choice(values) => {
                values[(unit(rng) * values.len() as f64) as usize % values.len()].clone()
            }
        }
    }

    /// The values the distribution can reach at its ends (every value, for `choice`).
    fn extremes(&self) -> Vec<(&'static str, Value)> {
        match self {
            Distribution::Uniform { min, max }
            | Distribution::LogUniform { min, max }
            | Distribution::Normal { min, max, .. } => {
                vec![("min", Value::Float(*min)), ("max", Value::Float(*max))]
            }
            Distribution::Choice(values) => values.iter().map(|v| ("value", v.clone())).collect(),
        }
    }
}

/// A uniform draw on [0, 1) from the top 53 bits of one 64-bit word (the same on every
/// platform and version of `rand`, which only supplies the words).
fn unit(rng: &mut impl Rng) -> f64 {
    (rng.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// The least share of a normal's draws its bounds must keep (each draw outside is redrawn).
const MIN_NORMAL_MASS: f64 = 1e-3;

/// The standard normal's cumulative distribution (Abramowitz & Stegun 7.1.26 for erf,
/// absolute error below 1.5e-7: ample for a bound on redraws).
fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-x * x).exp();
    0.5 * (1.0 + erf.copysign(z))
}

/// One step of a key's path.
#[derive(Clone, Debug, PartialEq, Eq)]
enum Step {
    Name(String),
    Index(usize),
}

/// One varied key: where, how, and the leaves of the scene it reaches.
#[derive(Clone, Debug)]
pub struct Entry {
    /// The key as the file spells it.
    pub key: String,
    /// Its distribution.
    pub dist: Distribution,
    /// Added to the scene's value instead of replacing it.
    pub add: bool,
    /// One draw for every leaf instead of one each.
    pub shared: bool,
    /// The leaves it sets, in draw order.
    leaves: Vec<Vec<Step>>,
}

/// A variation file applied to one scene: the entries and the base scene as TOML.
#[derive(Clone, Debug)]
pub struct Variation {
    /// The varied keys in file order (the order of the draws).
    pub entries: Vec<Entry>,
    /// Draws of one episode before it is refused.
    pub redraws: u32,
    /// The scene as TOML (every key, defaults included).
    base: Value,
    /// The scene file's path, for its folder (meshes) and messages.
    scene_path: PathBuf,
}

/// One episode's scene and the values drawn for it.
#[derive(Clone, Debug)]
pub struct Sample {
    /// The sampled scene, validated.
    pub scene: Scene,
    /// The sampled scene as a scene file.
    pub toml: String,
    /// Each leaf's path (`tissue.0.material.youngs_modulus`) and the value the scene got.
    pub params: Vec<(String, Value)>,
    /// Draws it took (1 when the first was valid).
    pub draws: u32,
}

fn leaf_name(path: &[Step]) -> String {
    path.iter()
        .map(|s| match s {
            Step::Name(n) => n.clone(),
            Step::Index(i) => i.to_string(),
        })
        .collect::<Vec<_>>()
        .join(".")
}

fn get<'a>(root: &'a Value, path: &[Step]) -> Option<&'a Value> {
    path.iter().try_fold(root, |v, s| match (s, v) {
        (Step::Name(n), Value::Table(t)) => t.get(n),
        (Step::Index(i), Value::Array(a)) => a.get(*i),
        _ => None,
    })
}

/// Sets the value at `path`, creating the last key in its table when missing.
fn set(root: &mut Value, path: &[Step], value: Value) {
    let (last, parent) = path.split_last().expect("a leaf path is never empty");
    let mut v = root;
    for s in parent {
        v = match (s, v) {
            (Step::Name(n), Value::Table(t)) => t.get_mut(n).expect("resolved path"),
            (Step::Index(i), Value::Array(a)) => &mut a[*i],
            _ => unreachable!("resolved path"),
        };
    }
    match (last, v) {
        (Step::Name(n), Value::Table(t)) => {
            t.insert(n.clone(), value);
        }
        (Step::Index(i), Value::Array(a)) => a[*i] = value,
        _ => unreachable!("resolved path"),
    }
}

fn is_number(v: &Value) -> bool {
    matches!(v, Value::Float(_) | Value::Integer(_))
}

fn number(v: &Value) -> f64 {
    match v {
        Value::Float(f) => *f,
        Value::Integer(i) => *i as f64,
        _ => f64::NAN,
    }
}

/// The keys a table or array offers, for an unknown key's message.
fn offered(v: &Value) -> String {
    match v {
        Value::Table(t) => t.keys().cloned().collect::<Vec<_>>().join(", "),
        Value::Array(a) => format!("indices 0 to {}, or *", a.len().saturating_sub(1)),
        _ => "none: it is a value, not a table".into(),
    }
}

/// The leaves `key` reaches in `root`; numeric arrays expand to their elements when the
/// distribution is numeric.
fn resolve(root: &Value, key: &str, numeric: bool, add: bool) -> Result<Vec<Vec<Step>>, String> {
    let mut paths: Vec<Vec<Step>> = vec![vec![]];
    let parts: Vec<&str> = key.split('.').collect();
    if key.is_empty() || parts.iter().any(|p| p.is_empty()) {
        return Err("an empty key or an empty part between dots".into());
    }
    for (n, part) in parts.iter().enumerate() {
        let last = n + 1 == parts.len();
        let mut next = Vec::new();
        for path in paths {
            let here = get(root, &path).expect("resolved so far");
            let so_far = leaf_name(&path);
            let at = if so_far.is_empty() {
                "the scene's top level".to_owned()
            } else {
                format!("`{so_far}`")
            };
            match here {
                Value::Array(a) if *part == "*" => {
                    next.extend((0..a.len()).map(|i| [path.clone(), vec![Step::Index(i)]].concat()))
                }
                Value::Array(a) => match part.parse::<usize>() {
                    Ok(i) if i < a.len() => next.push([path, vec![Step::Index(i)]].concat()),
                    _ => return Err(format!("no `{part}` in {at} (it has {})", offered(here))),
                },
                Value::Table(t) if t.contains_key(*part) || (last && !add) => {
                    // A key left at its default is absent from the TOML; the scene's own
                    // parser refuses a name it does not know (checked on load).
                    next.push([path, vec![Step::Name(part.to_string())]].concat())
                }
                _ => return Err(format!("no `{part}` in {at} (it has {})", offered(here))),
            }
        }
        paths = next;
    }
    if paths.is_empty() {
        return Err("`*` over an empty array reaches no value".into());
    }
    if !numeric {
        return Ok(paths);
    }
    let mut leaves = Vec::new();
    for path in paths {
        match get(root, &path) {
            Some(Value::Array(a)) if !a.is_empty() && a.iter().all(is_number) => {
                leaves.extend((0..a.len()).map(|i| [path.clone(), vec![Step::Index(i)]].concat()))
            }
            Some(v) if is_number(v) => leaves.push(path),
            None if !add => leaves.push(path),
            Some(v) => {
                return Err(format!(
                    "`{}` is {}, not a number a numeric distribution can set",
                    leaf_name(&path),
                    v.type_str()
                ))
            }
            None => return Err(format!("`{}` has no value to add to", leaf_name(&path))),
        }
    }
    Ok(leaves)
}

fn distribution(e: &EntryFile) -> Result<Distribution, String> {
    let need = |name: &str, v: Option<f64>| -> Result<f64, String> {
        match v {
            Some(x) if x.is_finite() => Ok(x),
            Some(x) => Err(format!("`{name}` = {x}: must be a finite number")),
            None => Err(format!("`dist = \"{}\"` needs `{name}`", e.dist)),
        }
    };
    let refuse_extra = |allowed: &[&str]| -> Result<(), String> {
        let given = [
            ("min", e.min.is_some()),
            ("max", e.max.is_some()),
            ("mean", e.mean.is_some()),
            ("std", e.std.is_some()),
            ("values", e.values.is_some()),
        ];
        match given.iter().find(|(n, g)| *g && !allowed.contains(n)) {
            Some((n, _)) => Err(format!(
                "`{n}` has no meaning for `dist = \"{}\"` (it takes {})",
                e.dist,
                allowed.join(", ")
            )),
            None => Ok(()),
        }
    };
    let range = |lo: f64, hi: f64| -> Result<(), String> {
        if lo < hi {
            Ok(())
        } else {
            Err(format!("empty range: min {lo} is not below max {hi}"))
        }
    };
    let dist = match e.dist.as_str() {
        "uniform" | "log_uniform" => {
            refuse_extra(&["min", "max"])?;
            let (min, max) = (need("min", e.min)?, need("max", e.max)?);
            range(min, max)?;
            if e.dist == "uniform" {
                Distribution::Uniform { min, max }
            } else if min <= 0.0 {
                return Err(format!(
                    "log_uniform needs min > 0 (its logarithm is drawn), got {min}"
                ));
            } else {
                Distribution::LogUniform { min, max }
            }
        }
        "normal" => {
            refuse_extra(&["mean", "std", "min", "max"])?;
            let (mean, std) = (need("mean", e.mean)?, need("std", e.std)?);
            let (min, max) = (need("min", e.min)?, need("max", e.max)?);
            range(min, max)?;
            if std <= 0.0 {
                return Err(format!("std must be > 0, got {std}"));
            }
            // Bounds that keep little of the bell would take endless redraws.
            let kept = normal_cdf((max - mean) / std) - normal_cdf((min - mean) / std);
            if kept < MIN_NORMAL_MASS {
                return Err(format!(
                    "the bounds [{min}, {max}] keep {:.2e} of the draws of a normal with mean \
                     {mean} and std {std} (at least {MIN_NORMAL_MASS} needed)",
                    kept
                ));
            }
            Distribution::Normal {
                mean,
                std,
                min,
                max,
            }
        }
        "choice" => {
            refuse_extra(&["values"])?;
            if e.add {
                return Err("`add = true` needs a numeric distribution, not `choice`".into());
            }
            match &e.values {
                Some(v) if !v.is_empty() => Distribution::Choice(v.clone()),
                _ => return Err("`choice` needs a non-empty `values` list".into()),
            }
        }
        other => {
            return Err(format!(
                "unknown distribution `{other}` (uniform, log_uniform, normal or choice)"
            ))
        }
    };
    Ok(dist)
}

/// Validates a scene given as TOML the way `check` validates a scene file: its keys, then
/// its arms against their URDFs (home joints inside the joint limits).
fn check(value: &Value, scene_path: &Path) -> Result<(Scene, String), String> {
    let text = toml::to_string(value).map_err(|e| format!("not writable as TOML: {e}"))?;
    match config::from_str(&text, scene_path) {
        Ok(scene) => {
            let problems = crate::sim::check_arm_urdfs(&scene);
            if problems.is_empty() {
                Ok((scene, text))
            } else {
                Err(problems
                    .iter()
                    .map(|p| p.to_string())
                    .collect::<Vec<_>>()
                    .join("; "))
            }
        }
        Err(config::SceneError::Invalid { problems, .. }) => Err(problems
            .iter()
            .map(|p| p.to_string())
            .collect::<Vec<_>>()
            .join("; ")),
        Err(e) => Err(e.to_string()),
    }
}

impl Variation {
    /// Reads a variation file for `scene` (loaded from `scene_path`); refuses it with every
    /// problem named (see the module docs).
    pub fn load(path: &Path, scene: &Scene, scene_path: &Path) -> Result<Variation, String> {
        let text = crate::files::read_regular(path)
            .map_err(|e| format!("{}: cannot read variation file: {e}", path.display()))?;
        Self::from_str(&text, path, scene, scene_path)
    }

    /// Parses variation text (`path` names it in messages) for `scene`.
    pub fn from_str(
        text: &str,
        path: &Path,
        scene: &Scene,
        scene_path: &Path,
    ) -> Result<Variation, String> {
        let file: VaryFile = toml::from_str(text)
            .map_err(|e| format!("{}: not a valid variation file: {e}", path.display()))?;
        let base = Value::try_from(scene)
            .map_err(|e| format!("{}: the scene as TOML: {e}", scene_path.display()))?;
        let mut problems = String::new();
        let mut entries = Vec::new();
        for (i, e) in file.vary.iter().enumerate() {
            let entry = distribution(e).and_then(|dist| {
                let numeric = !matches!(dist, Distribution::Choice(_));
                let leaves = resolve(&base, &e.key, numeric, e.add)?;
                Ok(Entry {
                    key: e.key.clone(),
                    dist,
                    add: e.add,
                    shared: e.shared,
                    leaves,
                })
            });
            match entry {
                Ok(entry) => entries.push(entry),
                Err(why) => {
                    let _ = writeln!(problems, "  vary[{i}] key `{}`: {why}", e.key);
                }
            }
        }
        if file.vary.is_empty() {
            let _ = writeln!(problems, "  no [[vary]] entry: nothing would vary");
        }
        let redraws = file.redraws.unwrap_or(DEFAULT_REDRAWS);
        if redraws == 0 {
            let _ = writeln!(problems, "  redraws = 0: at least one draw is needed");
        }
        let variation = Variation {
            entries,
            redraws,
            base,
            scene_path: scene_path.to_owned(),
        };
        if problems.is_empty() {
            for (i, entry) in variation.entries.iter().enumerate() {
                for (bound, value) in entry.dist.extremes() {
                    let mut scene = variation.base.clone();
                    for leaf in &entry.leaves {
                        let v = variation.leaf_value(entry, leaf, &value);
                        set(&mut scene, leaf, v);
                    }
                    if let Err(why) = check(&scene, scene_path) {
                        let _ = writeln!(
                            problems,
                            "  vary[{i}] key `{}`: {bound} {} leaves the valid range: {why}",
                            entry.key, value
                        );
                    }
                }
            }
        }
        if problems.is_empty() {
            Ok(variation)
        } else {
            Err(format!(
                "{}: refused for scene {}:\n{}",
                path.display(),
                scene_path.display(),
                problems.trim_end()
            ))
        }
    }

    /// The value a leaf gets from a draw: added to the scene's when `add`, rounded for an
    /// integer key.
    fn leaf_value(&self, entry: &Entry, leaf: &[Step], drawn: &Value) -> Value {
        let old = get(&self.base, leaf);
        if matches!(entry.dist, Distribution::Choice(_)) {
            return drawn.clone();
        }
        let x = number(drawn)
            + if entry.add {
                old.map_or(0.0, number)
            } else {
                0.0
            };
        match old {
            Some(Value::Integer(_)) => Value::Integer(x.round() as i64),
            _ => Value::Float(x),
        }
    }

    /// Draws one episode's scene from `rng`: every leaf in file order, again (up to
    /// `redraws` times) while the scene fails validation.
    pub fn sample(&self, rng: &mut impl Rng) -> Result<Sample, String> {
        let mut last = String::new();
        for draw in 1..=self.redraws {
            let mut scene = self.base.clone();
            let mut params = Vec::new();
            for entry in &self.entries {
                let shared = entry.shared.then(|| entry.dist.sample(rng));
                for leaf in &entry.leaves {
                    let drawn = shared.clone().unwrap_or_else(|| entry.dist.sample(rng));
                    let value = self.leaf_value(entry, leaf, &drawn);
                    params.push((leaf_name(leaf), value.clone()));
                    set(&mut scene, leaf, value);
                }
            }
            match check(&scene, &self.scene_path) {
                Ok((scene, toml)) => {
                    return Ok(Sample {
                        scene,
                        toml,
                        params,
                        draws: draw,
                    })
                }
                Err(why) => {
                    let drawn: Vec<String> =
                        params.iter().map(|(k, v)| format!("{k} = {v}")).collect();
                    last = format!("{why} (drawn: {})", drawn.join(", "));
                }
            }
        }
        Err(format!(
            "no valid scene in {} draw(s); the last: {last}",
            self.redraws
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SCENE: &str = include_str!("../../tests/scenes/small_scripted.toml");

    fn variation(text: &str) -> Result<Variation, String> {
        let path = Path::new("tests/scenes/small_scripted.toml");
        let scene = config::from_str(SCENE, path).unwrap();
        Variation::from_str(text, Path::new("vary.toml"), &scene, path)
    }

    fn param(sample: &Sample, key: &str) -> f64 {
        let (_, v) = sample.params.iter().find(|(k, _)| k == key).unwrap();
        number(v)
    }

    #[test]
    fn add_shared_and_integer_keys() {
        let v = variation(
            "[[vary]]\nkey = \"tool.0.keyframe.*.position.2\"\ndist = \"uniform\"\nadd = true\n\
             shared = true\nmin = -0.001\nmax = 0.001\n\
             [[vary]]\nkey = \"tissue.0.particles_per_axis\"\ndist = \"uniform\"\nmin = 1.0\nmax = 3.0\n",
        )
        .unwrap();
        let mut rng = crate::dataset::episode_rng(1, 2);
        let s = v.sample(&mut rng).unwrap();
        // One draw moves both keyframes (0.036 and 0.020 in the file) by the same offset.
        let (z0, z1) = (
            param(&s, "tool.0.keyframe.0.position.2"),
            param(&s, "tool.0.keyframe.1.position.2"),
        );
        assert!(((z0 - 0.036) - (z1 - 0.020)).abs() < 1e-12, "{z0} {z1}");
        assert!((z0 - 0.036).abs() <= 0.001);
        assert_eq!(s.scene.tools[0].keyframes[1].position[2], z1);
        let n = &s
            .params
            .iter()
            .find(|(k, _)| k == "tissue.0.particles_per_axis")
            .unwrap()
            .1;
        assert!(matches!(n, Value::Integer(1..=3)), "{n}");
        // The same stream draws the same scene.
        let again = v.sample(&mut crate::dataset::episode_rng(1, 2)).unwrap();
        assert_eq!(again.toml, s.toml);
    }

    #[test]
    fn draws_stay_inside_their_bounds() {
        let v = variation(
            "[[vary]]\nkey = \"tissue.0.material.youngs_modulus\"\ndist = \"log_uniform\"\n\
             min = 500.0\nmax = 5000.0\n\
             [[vary]]\nkey = \"tissue.0.material.damping\"\ndist = \"normal\"\nmean = 5.0\n\
             std = 4.0\nmin = 4.0\nmax = 6.0\n",
        )
        .unwrap();
        for i in 0..50 {
            let s = v.sample(&mut crate::dataset::episode_rng(0, i)).unwrap();
            let e = s.scene.tissues[0].material.youngs_modulus;
            let d = s.scene.tissues[0].material.damping;
            assert!(
                (500.0..5000.0).contains(&e) && (4.0..=6.0).contains(&d),
                "{e} {d}"
            );
        }
    }

    #[test]
    fn normal_bounds_that_keep_almost_nothing_are_refused() {
        let e = variation(
            "[[vary]]\nkey = \"tissue.0.material.damping\"\ndist = \"normal\"\nmean = 0.0\n\
             std = 0.1\nmin = 4.0\nmax = 6.0\n",
        )
        .unwrap_err();
        assert!(
            e.contains("keep") && e.contains("tissue.0.material.damping"),
            "{e}"
        );
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-7);
        assert!((normal_cdf(1.96) - 0.975).abs() < 1e-4);
    }

    #[test]
    fn a_combination_no_draw_can_satisfy_is_refused_after_the_redraws() {
        // Each bound alone keeps the keyframes in order; together t0 > t1 is possible, and
        // with t1 moved to 0.05-0.1 and t0 to 0.1-0.2 every draw is out of order.
        let v = variation(
            "redraws = 5\n[[vary]]\nkey = \"tool.0.keyframe.1.t\"\ndist = \"uniform\"\n\
             min = 0.05\nmax = 0.1\n\
             [[vary]]\nkey = \"tool.0.keyframe.0.t\"\ndist = \"uniform\"\nmin = 0.1\nmax = 0.2\n",
        );
        let e = match v {
            Ok(v) => v
                .sample(&mut crate::dataset::episode_rng(0, 0))
                .unwrap_err(),
            Err(e) => e,
        };
        assert!(e.contains("keyframe"), "{e}");
    }

    /// The endoscope's view varies through the ECM's joints (the camera rides at its tip):
    /// every drawn scene is valid and the poses differ; a bound past the URDF's joint limit
    /// is refused when the file loads.
    #[test]
    fn the_camera_pose_varies_through_the_ecm_joints() {
        let path = Path::new("tests/scenes/camera.toml");
        let text = include_str!("../../tests/scenes/camera.toml");
        let scene = config::from_str(text, path).unwrap();
        let ecm = scene.arms.iter().position(|a| a.name == "ECM").unwrap();
        let vary = |min: f64, max: f64| {
            format!(
                "[[vary]]\nkey = \"arm.{ecm}.home_joints.0\"\ndist = \"uniform\"\nadd = true\n\
                 min = {min}\nmax = {max}\n\
                 [[vary]]\nkey = \"arm.{ecm}.home_joints.1\"\ndist = \"normal\"\nadd = true\n\
                 mean = 0.0\nstd = 0.05\nmin = -0.1\nmax = 0.1\n"
            )
        };
        let v =
            Variation::from_str(&vary(-0.2, 0.2), Path::new("vary.toml"), &scene, path).unwrap();
        let mut rng = crate::dataset::episode_rng(3, 0);
        let home = scene.arms[ecm].home_joints.clone();
        let mut seen = Vec::new();
        for _ in 0..20 {
            let s = v.sample(&mut rng).unwrap();
            let q = &s.scene.arms[ecm].home_joints;
            assert!((q[0] - home[0]).abs() <= 0.2 && (q[1] - home[1]).abs() <= 0.1);
            assert_eq!(q[2..], home[2..]);
            seen.push(q[0]);
        }
        seen.sort_by(f64::total_cmp);
        seen.dedup();
        assert_eq!(seen.len(), 20, "every episode draws its own yaw");
        // The classic ECM's yaw stops at ±1.58 rad: a bound past it is refused on load.
        let e = Variation::from_str(&vary(-3.0, 0.2), Path::new("vary.toml"), &scene, path)
            .unwrap_err();
        assert!(e.contains("home_joints"), "{e}");
    }
}
