//! SROS2 (issue 39): the node's participant under DDS Security, with a keystore this test
//! makes in SROS2's layout with the `openssl` command line (an identity and permissions CA,
//! a signed governance document, and one enclave per participant: `cert.pem`, `key.pem`,
//! `identity_ca.cert.pem`, `permissions_ca.cert.pem`, `governance.p7s`, `permissions.p7s`).
//!
//! The node runs with `ROS_SECURITY_ENABLE=true` and `ROS_SECURITY_STRATEGY=Enforce` in the
//! enclave named after it. Its peers are ros2-client participants of this crate (RustDDS's
//! security plugins): the PyPI Fast DDS build that rclpy uses has no DDS Security (its
//! library carries no PKI-DH authentication plugin), so rclpy cannot take part.
//! - a **commander** whose permissions grant every topic reads `measured_js` and moves the
//!   arm with `move_jp`;
//! - an **unsecured** participant, and a **rogue** one with an identity and permissions
//!   from a CA of its own, each send `move_jp` for seconds: the arm does not move, and
//!   neither of them receives a single `measured_js`;
//! - an **observer** whose permissions grant reading only receives `measured_js`, and its
//!   `move_jp` writer is refused.
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set. Needs the `sros2` feature (Cargo.toml's `[[test]]` entry).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use dvrk_tissue_sim::ros::msgs::JointState;
use ros2_client::{Context, ContextOptions, NodeName, NodeOptions, QosProfile};

mod support;
use support::dds::{network_prerequisites, topic};
use support::node::NodeProcess;
use support::{binary, output_of_success};

const SMALL: [&str; 4] = ["--scene", "tests/scenes/small.toml", "--backend", "cpu"];
const DOMAIN: u16 = 86;

/// `openssl ARGS` in `dir`; fails the test with openssl's own words.
fn openssl(dir: &Path, args: &[&str]) {
    output_of_success(Command::new("openssl").current_dir(dir).args(args));
}

/// A new P-256 private key at `path` (relative to `dir`), the curve SROS2's keys use.
fn new_key(dir: &Path, path: &str) {
    openssl(
        dir,
        &[
            "genpkey",
            "-algorithm",
            "EC",
            "-pkeyopt",
            "ec_paramgen_curve:prime256v1",
            "-out",
            path,
        ],
    );
}

/// Who may publish and subscribe what (DDS topic names, `*` a wildcard).
struct Grant<'a> {
    publish: &'a [&'a str],
    subscribe: &'a [&'a str],
}

const EVERYTHING: Grant = Grant {
    publish: &["*"],
    subscribe: &["*"],
};

/// An SROS2 keystore: one CA for identities and permissions (as `ros2 security
/// create_keystore` makes it), its signed governance, and the enclaves added.
struct Keystore {
    root: tempfile::TempDir,
}

impl Keystore {
    fn new() -> Keystore {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path();
        for sub in ["public", "private", "enclaves"] {
            std::fs::create_dir(dir.join(sub)).unwrap();
        }
        new_key(dir, "private/ca.key.pem");
        openssl(
            dir,
            &[
                "req",
                "-x509",
                "-new",
                "-sha256",
                "-days",
                "3650",
                "-key",
                "private/ca.key.pem",
                "-subj",
                "/CN=sros2testCA",
                "-out",
                "public/ca.cert.pem",
            ],
        );
        std::fs::write(dir.join("enclaves/governance.xml"), GOVERNANCE).unwrap();
        let keystore = Keystore { root };
        keystore.sign("enclaves/governance.xml", "enclaves/governance.p7s");
        keystore
    }

    fn path(&self) -> &Path {
        self.root.path()
    }

    /// `input` signed by the CA as S/MIME (PKCS#7), as DDS Security reads it.
    fn sign(&self, input: &str, output: &str) {
        openssl(
            self.path(),
            &[
                "smime",
                "-sign",
                "-text",
                "-in",
                input,
                "-out",
                output,
                "-signer",
                "public/ca.cert.pem",
                "-inkey",
                "private/ca.key.pem",
            ],
        );
    }

    /// The enclave `name` ("/commander"): a key, an identity `CN=<name>` the CA signed, and
    /// `grant` as its signed permissions; returns its folder.
    fn enclave(&self, name: &str, grant: &Grant) -> PathBuf {
        let rel = format!("enclaves/{}", name.trim_start_matches('/'));
        let dir = self.path().join(&rel);
        std::fs::create_dir_all(&dir).unwrap();
        new_key(self.path(), &format!("{rel}/key.pem"));
        // A slash inside a value is escaped in openssl's -subj syntax.
        let subject = format!("/CN={}", name.replace('/', "\\/"));
        openssl(
            self.path(),
            &[
                "req",
                "-new",
                "-key",
                &format!("{rel}/key.pem"),
                "-subj",
                &subject,
                "-out",
                &format!("{rel}/request.pem"),
            ],
        );
        openssl(
            self.path(),
            &[
                "x509",
                "-req",
                "-sha256",
                "-days",
                "3650",
                "-set_serial",
                "1",
                "-in",
                &format!("{rel}/request.pem"),
                "-CA",
                "public/ca.cert.pem",
                "-CAkey",
                "private/ca.key.pem",
                "-out",
                &format!("{rel}/cert.pem"),
            ],
        );
        for ca in ["identity_ca.cert.pem", "permissions_ca.cert.pem"] {
            std::fs::copy(self.path().join("public/ca.cert.pem"), dir.join(ca)).unwrap();
        }
        std::fs::copy(
            self.path().join("enclaves/governance.p7s"),
            dir.join("governance.p7s"),
        )
        .unwrap();
        std::fs::write(dir.join("permissions.xml"), permissions(name, grant)).unwrap();
        self.sign(
            &format!("{rel}/permissions.xml"),
            &format!("{rel}/permissions.p7s"),
        );
        dir
    }
}

/// SROS2's default governance: no unauthenticated participant, discovery and data
/// encrypted, every topic's reading and writing under access control.
const GOVERNANCE: &str = r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_governance.xsd">
  <domain_access_rules>
    <domain_rule>
      <domains><id_range><min>0</min><max>230</max></id_range></domains>
      <allow_unauthenticated_participants>false</allow_unauthenticated_participants>
      <enable_join_access_control>true</enable_join_access_control>
      <discovery_protection_kind>ENCRYPT</discovery_protection_kind>
      <liveliness_protection_kind>ENCRYPT</liveliness_protection_kind>
      <rtps_protection_kind>SIGN</rtps_protection_kind>
      <topic_access_rules>
        <topic_rule>
          <topic_expression>*</topic_expression>
          <enable_discovery_protection>true</enable_discovery_protection>
          <enable_liveliness_protection>true</enable_liveliness_protection>
          <enable_read_access_control>true</enable_read_access_control>
          <enable_write_access_control>true</enable_write_access_control>
          <metadata_protection_kind>ENCRYPT</metadata_protection_kind>
          <data_protection_kind>ENCRYPT</data_protection_kind>
        </topic_rule>
      </topic_access_rules>
    </domain_rule>
  </domain_access_rules>
</dds>
"#;

/// The permissions document of the enclave `name`: `grant` on this test's domain.
fn permissions(name: &str, grant: &Grant) -> String {
    let topics = |list: &[&str]| {
        list.iter()
            .map(|t| format!("<topic>{t}</topic>"))
            .collect::<String>()
    };
    format!(
        r#"<?xml version="1.0" encoding="UTF-8"?>
<dds xmlns:xsi="http://www.w3.org/2001/XMLSchema-instance" xsi:noNamespaceSchemaLocation="http://www.omg.org/spec/DDS-SECURITY/20170901/omg_shared_ca_permissions.xsd">
  <permissions>
    <grant name="{name}">
      <subject_name>CN={name}</subject_name>
      <validity><not_before>2020-01-01T00:00:00</not_before><not_after>2100-01-01T00:00:00</not_after></validity>
      <allow_rule>
        <domains><id>{DOMAIN}</id></domains>
        <publish><topics>{}</topics></publish>
        <subscribe><topics>{}</topics></subscribe>
      </allow_rule>
      <default>DENY</default>
    </grant>
  </permissions>
</dds>
"#,
        topics(grant.publish),
        topics(grant.subscribe)
    )
}

fn reliable() -> QosProfile {
    QosProfile::publisher_default().history(ros2_client::qos::History::KeepLast { depth: 10 })
}

/// A peer of the node on this test's domain: secured by `enclave`, or not at all.
struct Peer {
    _context: Context,
    node: ros2_client::Node,
}

impl Peer {
    fn new(name: &str, enclave: Option<&Path>) -> Peer {
        let mut options = ContextOptions::new().domain_id(DOMAIN);
        if let Some(dir) = enclave {
            options = options.enable_security(dir, String::new());
        }
        let context = Context::with_options(options).unwrap();
        let node = context
            .new_node(NodeName::new("/", name).unwrap(), NodeOptions::new())
            .unwrap();
        Peer {
            _context: context,
            node,
        }
    }

    fn measured_js(&mut self) -> ros2_client::Subscription<JointState> {
        let t = topic::<JointState>(&mut self.node, "/PSM1/measured_js", &reliable());
        self.node
            .create_subscription::<JointState>(&t, Some(reliable()))
            .unwrap()
    }

    fn move_jp(&mut self) -> Result<ros2_client::Publisher<JointState>, ros2_client::CreateError> {
        let t = topic::<JointState>(&mut self.node, "/PSM1/move_jp", &reliable());
        self.node.create_publisher::<JointState>(&t, None)
    }
}

/// The newest joint positions `reader` holds, if any arrived.
fn newest(reader: &ros2_client::Subscription<JointState>) -> Option<Vec<f64>> {
    std::iter::from_fn(|| reader.take().ok().flatten())
        .last()
        .map(|(m, _)| m.position)
}

/// Polls `reader` until `done` holds for the newest positions or `patience` ends.
fn wait_for(
    reader: &ros2_client::Subscription<JointState>,
    patience: Duration,
    done: impl Fn(&[f64]) -> bool,
) -> Option<Vec<f64>> {
    let deadline = Instant::now() + patience;
    let mut last = None;
    while Instant::now() < deadline {
        if let Some(p) = newest(reader) {
            if done(&p) {
                return Some(p);
            }
            last = Some(p);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    last.filter(|p| done(p))
}

fn command(position: &[f64]) -> JointState {
    JointState {
        position: position.to_vec(),
        ..Default::default()
    }
}

#[test]
fn enforce_refuses_a_keystore_without_the_nodes_enclave() {
    let keystore = Keystore::new();
    keystore.enclave("/someone_else", &EVERYTHING);
    let out = binary()
        .arg("run")
        .args(SMALL)
        .env("ROS_SECURITY_ENABLE", "true")
        .env("ROS_SECURITY_STRATEGY", "Enforce")
        .env("ROS_SECURITY_KEYSTORE", keystore.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(
        stderr.contains("enclave \"/dvrk_tissue_sim\"") && stderr.contains("lacks"),
        "{stderr}"
    );
    println!("ok: Enforce without the node's enclave: {}", stderr.trim());
}

#[test]
fn only_permitted_participants_read_and_command_the_secured_arm() {
    if !network_prerequisites(false) {
        return;
    }
    let keystore = Keystore::new();
    keystore.enclave("/dvrk_tissue_sim", &EVERYTHING);
    let commander = keystore.enclave("/commander", &EVERYTHING);
    let observer = keystore.enclave(
        "/observer",
        &Grant {
            publish: &["ros_discovery_info", "rt/rosout", "rt/parameter_events"],
            subscribe: &["*"],
        },
    );
    // The attacker's own CA, identity and permissions granting itself everything.
    let rogue_keystore = Keystore::new();
    let rogue = rogue_keystore.enclave("/commander", &EVERYTHING);

    let env = [
        ("ROS_SECURITY_ENABLE", "true".as_ref()),
        ("ROS_SECURITY_STRATEGY", "Enforce".as_ref()),
        ("ROS_SECURITY_KEYSTORE", keystore.path().as_os_str()),
    ];
    let node = NodeProcess::start_with_env(&SMALL, &env, DOMAIN);

    let mut commander = Peer::new("commander", Some(&commander));
    let commander_js = commander.measured_js();
    let start = wait_for(&commander_js, Duration::from_secs(40), |_| true)
        .unwrap_or_else(|| panic!("the commander read no measured_js\n{}", node.log()));
    assert!(node.log().contains("DDS Security on"), "{}", node.log());
    println!("ok: the commander reads measured_js {start:.4?}");

    // Seconds of move_jp from the unsecured and the rogue participant.
    let mut unsecured = Peer::new("unsecured", None);
    let mut rogue = Peer::new("rogue", Some(&rogue));
    let unsecured_js = unsecured.measured_js();
    let rogue_js = rogue.measured_js();
    let unsecured_move = unsecured.move_jp().unwrap();
    let rogue_move = rogue.move_jp().unwrap();
    let mut forged = start.clone();
    forged[0] += 0.3;
    let sending = Instant::now();
    while sending.elapsed() < Duration::from_secs(6) {
        unsecured_move.publish(command(&forged)).unwrap();
        rogue_move.publish(command(&forged)).unwrap();
        std::thread::sleep(Duration::from_millis(100));
    }
    let now = newest(&commander_js).expect("measured_js stopped");
    let moved = now
        .iter()
        .zip(&start)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(
        moved < 1e-6,
        "an unpermitted participant moved the arm by {moved} rad\n{}",
        node.log()
    );
    assert!(
        newest(&unsecured_js).is_none(),
        "the unsecured peer read measured_js"
    );
    assert!(
        newest(&rogue_js).is_none(),
        "the rogue peer read measured_js"
    );
    println!(
        "ok: 6 s of move_jp from an unsecured and a rogue participant: the arm moved {moved:.1e} \
         rad, and neither read a measured_js"
    );

    // The refused peers leave before the observer joins: the node need not keep retrying
    // their handshakes while it authenticates the observer.
    drop((unsecured_move, rogue_move, unsecured_js, rogue_js));
    drop((unsecured, rogue));

    // The observer reads; its permissions refuse it a move_jp writer.
    let mut observer = Peer::new("observer", Some(&observer));
    let observer_js = observer.measured_js();
    assert!(
        wait_for(&observer_js, Duration::from_secs(30), |_| true).is_some(),
        "the observer read no measured_js\n{}",
        node.log()
    );
    let refused = observer.move_jp();
    assert!(refused.is_err(), "the observer was given a move_jp writer");
    println!(
        "ok: the observer reads measured_js; its move_jp writer: {:?}",
        refused.err()
    );

    // The commander's move_jp moves the arm.
    let commander_move = commander.move_jp().unwrap();
    let mut target = start.clone();
    target[1] += 0.1;
    let reached = {
        let deadline = Instant::now() + Duration::from_secs(20);
        let mut reached = None;
        while reached.is_none() && Instant::now() < deadline {
            commander_move.publish(command(&target)).unwrap();
            reached = wait_for(&commander_js, Duration::from_millis(500), |p| {
                (p[1] - target[1]).abs() < 1e-3
            });
        }
        reached
    };
    let reached =
        reached.unwrap_or_else(|| panic!("the commander's move_jp failed\n{}", node.log()));
    println!("ok: the commander's move_jp took the arm to {reached:.4?}");

    drop((commander_move, commander_js, observer_js));
    drop((commander, observer));
    let (status, log) = node.stop();
    assert!(status.is_some_and(|s| s.success()), "{status:?}\n{log}");
}
