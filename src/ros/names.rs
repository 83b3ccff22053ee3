//! ROS names: where a topic relative to the node's namespace lives on the graph. Inputs,
//! outputs, the node and the recorder all name topics the same way through here.

/// Absolute topic name of `relative` under `namespace`.
pub fn resolve(namespace: &str, relative: &str) -> String {
    let relative = relative.trim_start_matches('/');
    if namespace == "/" || namespace.is_empty() {
        format!("/{relative}")
    } else {
        format!("{}/{relative}", namespace.trim_end_matches('/'))
    }
}

/// Absolute name of `topic` (absolute, or relative to `namespace`) after the first remap rule
/// whose `from` names it, as ROS 2 applies `--ros-args -r FROM:=TO` (both sides resolve in
/// `namespace` the same way).
pub fn remap(namespace: &str, remaps: &[(String, String)], topic: &str) -> String {
    let absolute = |t: &str| {
        if t.starts_with('/') {
            t.to_owned()
        } else {
            resolve(namespace, t)
        }
    };
    let full = absolute(topic);
    remaps
        .iter()
        .find(|(from, _)| absolute(from) == full)
        .map(|(_, to)| absolute(to))
        .unwrap_or(full)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_resolve_under_the_namespace() {
        assert_eq!(resolve("/", "PSM1/measured_js"), "/PSM1/measured_js");
        assert_eq!(resolve("/sim", "tissue/points"), "/sim/tissue/points");
        assert_eq!(resolve("/a/b", "/x"), "/a/b/x");
    }

    #[test]
    fn remaps_match_resolved_names() {
        let rules = [
            ("tissue/points".to_owned(), "cloud".to_owned()),
            ("/tf".to_owned(), "/sim_tf".to_owned()),
        ];
        assert_eq!(remap("/sim", &rules, "tissue/points"), "/sim/cloud");
        assert_eq!(remap("/sim", &rules, "/sim/tissue/points"), "/sim/cloud");
        assert_eq!(remap("/sim", &rules, "/tf"), "/sim_tf");
        assert_eq!(
            remap("/sim", &rules, "PSM1/measured_js"),
            "/sim/PSM1/measured_js"
        );
    }
}
