//! SROS2: which keystore enclave secures the node's DDS participant, read from the
//! environment variables ROS 2 defines.
//!
//! - `ROS_SECURITY_ENABLE=true` (exactly, as ROS 2 compares it) turns security on; any other
//!   value or none leaves the participant unsecured.
//! - `ROS_SECURITY_KEYSTORE` is the keystore (`ros2 security create_keystore`'s layout); the
//!   enclave's files are in `<keystore>/enclaves/<enclave>/`: `identity_ca.cert.pem`,
//!   `cert.pem`, `key.pem` (PKCS#8, unencrypted, as SROS2 writes it),
//!   `permissions_ca.cert.pem`, `governance.p7s` and `permissions.p7s`.
//! - The enclave is `ROS_SECURITY_ENCLAVE_OVERRIDE` when set, otherwise the node's fully
//!   qualified name (`/dvrk_tissue_sim`, or `/ns/name` with `--namespace`): one identity per
//!   node, so a keystore made with `ros2 security create_enclave <keystore> /dvrk_tissue_sim`
//!   serves the default node. (`ROS_SECURITY_ENCLAVE_OVERRIDE=/` takes ROS 2's root enclave.)
//! - `ROS_SECURITY_STRATEGY=Enforce` refuses to start when the enclave's files are missing
//!   (or this build has no DDS Security); otherwise (`Permissive`, ROS 2's default) the node
//!   warns and runs unsecured, as an rcl node does.
//!
//! Secured, the participant authenticates every peer against the identity CA, checks each
//! peer's signed permissions against the permissions CA, and protects what the governance
//! document asks (RustDDS's builtin plugins, DDS Security 1.1). A peer without an identity
//! the CA signed, or whose permissions do not grant the topic, is not matched: it neither
//! sees the node's topics nor commands the arms (`tests/sros2.rs`).
//!
//! DDS Security links OpenSSL, so it is the cargo feature `sros2` (off by default: the
//! default build needs no system library); a build without it refuses `Enforce` and warns
//! under `Permissive`.

use std::path::{Component, Path, PathBuf};

use crate::ros::node::NodeError;

/// The files ROS 2 names in an enclave (rmw_dds_common's security file names).
pub const ENCLAVE_FILES: [&str; 6] = [
    "identity_ca.cert.pem",
    "cert.pem",
    "key.pem",
    "permissions_ca.cert.pem",
    "governance.p7s",
    "permissions.p7s",
];

/// Whether this build can secure its participant (the `sros2` feature).
pub const SUPPORTED: bool = cfg!(feature = "sros2");

/// The security environment variables, as read (`None` = unset).
#[derive(Debug, Default, Clone)]
pub struct SecurityEnv {
    /// `ROS_SECURITY_ENABLE`.
    pub enable: Option<String>,
    /// `ROS_SECURITY_STRATEGY`.
    pub strategy: Option<String>,
    /// `ROS_SECURITY_KEYSTORE`.
    pub keystore: Option<PathBuf>,
    /// `ROS_SECURITY_ENCLAVE_OVERRIDE`.
    pub enclave_override: Option<String>,
}

impl SecurityEnv {
    /// This process's security environment.
    pub fn from_env() -> Self {
        let var = |k: &str| std::env::var(k).ok();
        SecurityEnv {
            enable: var("ROS_SECURITY_ENABLE"),
            strategy: var("ROS_SECURITY_STRATEGY"),
            keystore: std::env::var_os("ROS_SECURITY_KEYSTORE").map(PathBuf::from),
            enclave_override: var("ROS_SECURITY_ENCLAVE_OVERRIDE"),
        }
    }

    /// The enclave folder that secures the node `node_fqn` (its fully qualified name):
    /// `Ok(None)` to run unsecured (security off, or `Permissive` and the files missing;
    /// the reason is logged at warn), an error under `Enforce`.
    pub fn enclave_dir(&self, node_fqn: &str, supported: bool) -> Result<Option<PathBuf>, String> {
        if self.enable.as_deref() != Some("true") {
            return Ok(None);
        }
        let enforce = match self.strategy.as_deref().map(str::trim) {
            Some("Enforce") => true,
            None | Some("") | Some("Permissive") => false,
            Some(other) => {
                return Err(format!(
                    "ROS_SECURITY_STRATEGY = {other:?}: expected Enforce or Permissive"
                ))
            }
        };
        let found = self.find_enclave(node_fqn, supported);
        match found {
            Ok(dir) => Ok(Some(dir)),
            Err(why) if enforce => Err(format!("{why} (ROS_SECURITY_STRATEGY = Enforce)")),
            Err(why) => {
                tracing::warn!(
                    "ROS_SECURITY_ENABLE = true, but {why}: running UNSECURED \
                     (ROS_SECURITY_STRATEGY = Permissive; set it to Enforce to refuse instead)"
                );
                Ok(None)
            }
        }
    }

    fn find_enclave(&self, node_fqn: &str, supported: bool) -> Result<PathBuf, String> {
        if !supported {
            return Err(
                "this build has no DDS Security: build with `--features sros2` \
                        (needs OpenSSL's headers, Debian's libssl-dev)"
                    .into(),
            );
        }
        let keystore = self
            .keystore
            .as_deref()
            .filter(|k| !k.as_os_str().is_empty())
            .ok_or("ROS_SECURITY_KEYSTORE is not set")?;
        let enclave = self.enclave_override.as_deref().unwrap_or(node_fqn);
        let dir = enclave_path(keystore, enclave)?;
        let missing: Vec<&str> = ENCLAVE_FILES
            .iter()
            .filter(|f| !dir.join(f).is_file())
            .copied()
            .collect();
        if missing.is_empty() {
            Ok(dir)
        } else {
            Err(format!(
                "enclave {enclave:?} in {} lacks {}",
                dir.display(),
                missing.join(", ")
            ))
        }
    }
}

/// `<keystore>/enclaves/<enclave>`: the enclave is an absolute ROS name ("/", "/a/b"); a
/// component that would leave the keystore ("..", ".") is refused.
fn enclave_path(keystore: &Path, enclave: &str) -> Result<PathBuf, String> {
    let refuse =
        || format!("enclave {enclave:?}: expected an absolute name such as /dvrk_tissue_sim");
    let relative = enclave.strip_prefix('/').ok_or_else(refuse)?;
    let relative = Path::new(relative);
    if !relative
        .components()
        .all(|c| matches!(c, Component::Normal(_)))
    {
        return Err(refuse());
    }
    Ok(keystore.join("enclaves").join(relative))
}

/// The enclave for the node `node_fqn` from this process's environment (see the module
/// docs); `None` runs the participant unsecured.
pub fn enclave_from_env(node_fqn: &str) -> Result<Option<PathBuf>, NodeError> {
    SecurityEnv::from_env()
        .enclave_dir(node_fqn, SUPPORTED)
        .map_err(|detail| NodeError::Ros {
            what: "DDS Security (SROS2)".into(),
            detail,
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn env(enable: &str, strategy: Option<&str>, keystore: Option<&Path>) -> SecurityEnv {
        SecurityEnv {
            enable: Some(enable.into()),
            strategy: strategy.map(Into::into),
            keystore: keystore.map(Path::to_path_buf),
            enclave_override: None,
        }
    }

    #[test]
    fn security_follows_ros_2s_variables() {
        let keystore = tempfile::tempdir().unwrap();
        let node = "/dvrk_tissue_sim";
        // Off unless exactly "true".
        assert_eq!(
            env("True", Some("Enforce"), None).enclave_dir(node, true),
            Ok(None)
        );
        // Enforce refuses a missing keystore, a missing enclave and a build without it.
        let missing = env("true", Some("Enforce"), None).enclave_dir(node, true);
        assert!(missing.unwrap_err().contains("ROS_SECURITY_KEYSTORE"));
        let e = env("true", Some("Enforce"), Some(keystore.path()));
        let lacking = e.enclave_dir(node, true).unwrap_err();
        assert!(
            lacking.contains("lacks identity_ca.cert.pem, cert.pem"),
            "{lacking}"
        );
        // Permissive runs unsecured instead.
        let p = env("true", None, Some(keystore.path()));
        assert_eq!(p.enclave_dir(node, true), Ok(None));
        // Every file present: the enclave named after the node.
        let dir = keystore.path().join("enclaves/dvrk_tissue_sim");
        std::fs::create_dir_all(&dir).unwrap();
        for f in ENCLAVE_FILES {
            std::fs::write(dir.join(f), "x").unwrap();
        }
        assert_eq!(e.enclave_dir(node, true), Ok(Some(dir.clone())));
        let unsupported = e.enclave_dir(node, false).unwrap_err();
        assert!(unsupported.contains("--features sros2"), "{unsupported}");
        assert_eq!(p.enclave_dir(node, false), Ok(None));
        // The override wins; it may not climb out of the keystore.
        let mut o = e.clone();
        o.enclave_override = Some("/../dvrk_tissue_sim".into());
        assert!(o
            .enclave_dir(node, true)
            .unwrap_err()
            .contains("absolute name"));
        o.enclave_override = Some("/other".into());
        assert!(o
            .enclave_dir(node, true)
            .unwrap_err()
            .contains("\"/other\""));
        // An unknown strategy is refused whatever the files.
        let s = env("true", Some("enforce"), Some(keystore.path()));
        assert!(s
            .enclave_dir(node, true)
            .unwrap_err()
            .contains("\"enforce\""));
    }
}
