//! Standard ROS 2 command-line arguments: `run ... --ros-args -r __ns:=/sim -r __node:=sim
//! -r from:=to -p use_sim_time:=true` works as for any ROS 2 node (`ros2 launch` and
//! `ros2 run` pass them).
//!
//! - `-r` / `--remap`: `__ns:=NS` (namespace), `__node:=NAME` or `__name:=NAME` (node name),
//!   `FROM:=TO` (a topic name; relative names resolve in the node's namespace);
//! - `-p` / `--param NAME:=VALUE`, for the parameters in [`PARAMETERS`]: `scene` (the scene
//!   file, instead of `--scene`), the frame and output rates (the scene's own keys,
//!   overriding the file, validated as the file's values are) and `use_sim_time` (accepted:
//!   every stamp the node publishes is simulated time already);
//! - several `--ros-args` blocks, each ended by `--` or the end of the command line.
//!
//! Anything else (`--params-file`, `--log-level`, `-e`, an undeclared parameter, a remap
//! without `:=`) is refused with the argument and the reason. The node serves its
//! parameters read-only on the standard services (`ros2 param list`, `ros2 param get`;
//! [`crate::ros::parameters`]).

use std::ffi::OsString;

use crate::config::Scene;

/// The parameters the node declares: name and what it sets.
pub const PARAMETERS: &[(&str, &str)] = &[
    (
        "use_sim_time",
        "bool; stamps are simulated time whatever its value",
    ),
    ("scene", "string; the scene file"),
    ("frame_rate_hz", "double; the scene's frame_rate_hz"),
    ("arm_rate_hz", "double; [outputs] arm_rate_hz"),
    ("points_rate_hz", "double; [outputs] points_rate_hz"),
    ("surface_rate_hz", "double; [outputs] surface_rate_hz"),
    ("wrench_rate_hz", "double; [outputs] wrench_rate_hz"),
    ("tf_rate_hz", "double; [outputs] tf_rate_hz"),
    ("thread_rate_hz", "double; [outputs] thread_rate_hz"),
    ("pieces_rate_hz", "double; [outputs] pieces_rate_hz"),
];

/// A parameter value given with `-p`.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamValue {
    /// `true` / `false`.
    Bool(bool),
    /// A number.
    Double(f64),
    /// Any other text.
    Text(String),
}

/// What `--ros-args` asked for.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RosArgs {
    /// `-r __ns:=...`.
    pub namespace: Option<String>,
    /// `-r __node:=...`.
    pub node_name: Option<String>,
    /// Topic remaps, in order: from, to (as given).
    pub remaps: Vec<(String, String)>,
    /// `-p name:=value`, in order.
    pub params: Vec<(String, ParamValue)>,
}

/// An argument `--ros-args` cannot take.
#[derive(Debug, thiserror::Error, PartialEq)]
#[error("--ros-args: `{argument}`: {reason}")]
pub struct RosArgsError {
    /// The argument as given.
    pub argument: String,
    /// Why it is refused.
    pub reason: String,
}

fn refuse(argument: &str, reason: impl Into<String>) -> RosArgsError {
    RosArgsError {
        argument: argument.to_owned(),
        reason: reason.into(),
    }
}

/// Splits a command line into the program's own arguments and the arguments of its
/// `--ros-args` blocks (each up to `--` or the end).
pub fn split(args: impl IntoIterator<Item = OsString>) -> (Vec<OsString>, Vec<String>) {
    let mut own = Vec::new();
    let mut ros = Vec::new();
    let mut in_ros = false;
    for arg in args {
        if arg == "--ros-args" {
            in_ros = true;
        } else if in_ros && arg == "--" {
            in_ros = false;
        } else if in_ros {
            ros.push(arg.to_string_lossy().into_owned());
        } else {
            own.push(arg);
        }
    }
    (own, ros)
}

impl RosArgs {
    /// Parses the arguments of the `--ros-args` blocks.
    pub fn parse(args: &[String]) -> Result<RosArgs, RosArgsError> {
        let mut parsed = RosArgs::default();
        let mut it = args.iter();
        while let Some(flag) = it.next() {
            match flag.as_str() {
                "-r" | "--remap" => {
                    let rule = it
                        .next()
                        .ok_or_else(|| refuse(flag, "expects a rule FROM:=TO after it"))?;
                    let (from, to) = rule
                        .split_once(":=")
                        .ok_or_else(|| refuse(rule, "a remap rule is FROM:=TO"))?;
                    if from.is_empty() || to.is_empty() || from.contains(':') {
                        return Err(refuse(
                            rule,
                            "a remap rule is FROM:=TO with non-empty names (node-targeted \
                             rules NODE:FROM:=TO are not supported)",
                        ));
                    }
                    match from {
                        "__ns" => parsed.namespace = Some(to.to_owned()),
                        "__node" | "__name" => parsed.node_name = Some(to.to_owned()),
                        _ if from.starts_with("__") => {
                            return Err(refuse(rule, "unknown special remap (known: __ns, __node)"))
                        }
                        _ => parsed.remaps.push((from.to_owned(), to.to_owned())),
                    }
                }
                "-p" | "--param" => {
                    let assignment = it
                        .next()
                        .ok_or_else(|| refuse(flag, "expects NAME:=VALUE after it"))?;
                    let (name, value) = assignment
                        .split_once(":=")
                        .ok_or_else(|| refuse(assignment, "a parameter is NAME:=VALUE"))?;
                    if !PARAMETERS.iter().any(|(p, _)| *p == name) {
                        let known: Vec<&str> = PARAMETERS.iter().map(|(p, _)| *p).collect();
                        return Err(refuse(
                            assignment,
                            format!("undeclared parameter (declared: {})", known.join(", ")),
                        ));
                    }
                    let value = parse_value(value);
                    let fits = match (name, &value) {
                        ("use_sim_time", ParamValue::Bool(_)) => true,
                        ("use_sim_time", _) => false,
                        ("scene", ParamValue::Text(_)) => true,
                        ("scene", _) => false,
                        (_, ParamValue::Double(_)) => true,
                        _ => false,
                    };
                    if !fits {
                        let wanted = PARAMETERS.iter().find(|(p, _)| *p == name).unwrap().1;
                        return Err(refuse(assignment, format!("expected {wanted}")));
                    }
                    parsed.params.push((name.to_owned(), value));
                }
                _ => {
                    return Err(refuse(
                        flag,
                        "not supported here (supported: -r/--remap FROM:=TO, -p/--param \
                         NAME:=VALUE)",
                    ))
                }
            }
        }
        Ok(parsed)
    }

    /// Sets the scene's rates given as parameters (validate the scene afterwards).
    pub fn apply_rates(&self, scene: &mut Scene) {
        for (name, value) in &self.params {
            let ParamValue::Double(v) = value else {
                continue;
            };
            let o = &mut scene.outputs;
            let slot = match name.as_str() {
                "frame_rate_hz" => &mut scene.frame_rate_hz,
                "arm_rate_hz" => &mut o.arm_rate_hz,
                "points_rate_hz" => &mut o.points_rate_hz,
                "surface_rate_hz" => &mut o.surface_rate_hz,
                "wrench_rate_hz" => &mut o.wrench_rate_hz,
                "tf_rate_hz" => &mut o.tf_rate_hz,
                "thread_rate_hz" => &mut o.thread_rate_hz,
                "pieces_rate_hz" => &mut o.pieces_rate_hz,
                _ => continue,
            };
            *slot = *v;
        }
    }

    /// Every declared parameter with the value this run uses: `scene_path`, the scene's
    /// rates and `use_sim_time` (false unless given).
    pub fn declared(&self, scene_path: &str, scene: &Scene) -> Vec<(String, ParamValue)> {
        let o = &scene.outputs;
        let use_sim_time = self
            .param("use_sim_time")
            .cloned()
            .unwrap_or(ParamValue::Bool(false));
        let rate = |name: &str, v: f64| (name.to_owned(), ParamValue::Double(v));
        vec![
            ("use_sim_time".to_owned(), use_sim_time),
            ("scene".to_owned(), ParamValue::Text(scene_path.to_owned())),
            rate("frame_rate_hz", scene.frame_rate_hz),
            rate("arm_rate_hz", o.arm_rate_hz),
            rate("points_rate_hz", o.points_rate_hz),
            rate("surface_rate_hz", o.surface_rate_hz),
            rate("wrench_rate_hz", o.wrench_rate_hz),
            rate("tf_rate_hz", o.tf_rate_hz),
            rate("thread_rate_hz", o.thread_rate_hz),
            rate("pieces_rate_hz", o.pieces_rate_hz),
        ]
    }

    /// The last value given for parameter `name`.
    pub fn param(&self, name: &str) -> Option<&ParamValue> {
        self.params
            .iter()
            .rev()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
    }
}

/// A value as ROS 2 reads one on the command line (YAML): booleans, numbers, else text.
fn parse_value(text: &str) -> ParamValue {
    match text {
        "true" | "True" | "TRUE" => ParamValue::Bool(true),
        "false" | "False" | "FALSE" => ParamValue::Bool(false),
        _ => match text.parse::<f64>() {
            Ok(v) if v.is_finite() => ParamValue::Double(v),
            _ => ParamValue::Text(text.trim_matches(|c| c == '"' || c == '\'').to_owned()),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_owned).collect()
    }

    #[test]
    fn namespace_node_remaps_and_parameters() {
        let (own, ros) = split(
            args("prog run --scene a.toml --ros-args -r __ns:=/sim -r __node:=sim -- --seconds 1")
                .into_iter()
                .map(OsString::from),
        );
        assert_eq!(own, ["prog", "run", "--scene", "a.toml", "--seconds", "1"]);
        let mut ros = ros;
        ros.extend(args(
            "-r tissue/points:=/cloud -p use_sim_time:=true -p arm_rate_hz:=50",
        ));
        let parsed = RosArgs::parse(&ros).unwrap();
        assert_eq!(parsed.namespace.as_deref(), Some("/sim"));
        assert_eq!(parsed.node_name.as_deref(), Some("sim"));
        assert_eq!(parsed.remaps, [("tissue/points".into(), "/cloud".into())]);
        assert_eq!(parsed.param("use_sim_time"), Some(&ParamValue::Bool(true)));
        assert_eq!(parsed.param("arm_rate_hz"), Some(&ParamValue::Double(50.0)));
    }

    #[test]
    fn bad_arguments_are_refused_with_the_reason() {
        for (line, says) in [
            ("-p speed:=3", "undeclared parameter"),
            ("-p use_sim_time:=yes", "expected bool"),
            ("-p arm_rate_hz:=fast", "expected double"),
            ("-r points", "FROM:=TO"),
            ("-r __foo:=x", "unknown special remap"),
            ("--params-file p.yaml", "not supported"),
            ("-p", "expects NAME:=VALUE"),
        ] {
            let e = RosArgs::parse(&args(line)).unwrap_err();
            assert!(e.to_string().contains(says), "{line}: {e}");
        }
    }
}
