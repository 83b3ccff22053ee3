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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn topics_resolve_under_the_namespace() {
        assert_eq!(resolve("/", "PSM1/measured_js"), "/PSM1/measured_js");
        assert_eq!(resolve("/sim", "tissue/points"), "/sim/tissue/points");
        assert_eq!(resolve("/a/b", "/x"), "/a/b/x");
    }
}
