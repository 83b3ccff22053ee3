//! The node as a child process and the rclpy scripts that drive it, for the tests that start
//! DDS participants.

use std::ffi::OsStr;
use std::path::PathBuf;
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::time::{Duration, Instant};

use super::dds::python;
use super::{binary, root};

/// `dvrk-tissue-sim run ARGS` on DDS domain `domain`, its log (stderr) in a temporary file.
/// Dropping it stops the node as Ctrl-C would.
pub struct NodeProcess {
    child: Child,
    log: PathBuf,
}

impl NodeProcess {
    /// The node on `scene` with its default backend.
    pub fn start(scene: &str, domain: u16) -> NodeProcess {
        NodeProcess::start_with(&["--scene", scene], domain)
    }

    /// The node with `args` after `run`.
    pub fn start_with(args: &[&str], domain: u16) -> NodeProcess {
        NodeProcess::start_with_env(args, &[], domain)
    }

    /// The node with `args` after `run` and the environment variables `env` set.
    pub fn start_with_env(args: &[&str], env: &[(&str, &OsStr)], domain: u16) -> NodeProcess {
        let log =
            std::env::temp_dir().join(format!("dvrk-node-{domain}-{}.log", std::process::id()));
        let child = binary()
            .arg("run")
            .args(args)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("NO_COLOR", "1")
            .envs(env.iter().copied())
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .expect("cannot start the node");
        NodeProcess { child, log }
    }

    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// What the node logged so far.
    pub fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// SIGINT, then up to 15 s for a clean exit (killed after that: `None`); the node's
    /// exit status and its whole log.
    pub fn stop(mut self) -> (Option<ExitStatus>, String) {
        let status = self.interrupt_and_wait(Duration::from_secs(15));
        (status, self.log())
    }

    fn interrupt_and_wait(&mut self, patience: Duration) -> Option<ExitStatus> {
        if let Ok(Some(status)) = self.child.try_wait() {
            return Some(status);
        }
        let _ = Command::new("kill")
            .args(["-INT", &self.child.id().to_string()])
            .status();
        let deadline = Instant::now() + patience;
        while Instant::now() < deadline {
            if let Ok(Some(status)) = self.child.try_wait() {
                return Some(status);
            }
            std::thread::sleep(Duration::from_millis(50));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
        None
    }
}

impl Drop for NodeProcess {
    fn drop(&mut self) {
        self.interrupt_and_wait(Duration::from_secs(5));
    }
}

/// `tests/ros/<script>` run by the venv's python on DDS domain `domain`, with Fast DDS and
/// its large-data profile, stdout unbuffered.
pub fn rclpy_command(script: &str, domain: u16) -> Command {
    let mut command = Command::new(python());
    command
        .current_dir(root().join("tests/ros"))
        .arg(script)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
        .env(
            "FASTDDS_DEFAULT_PROFILES_FILE",
            root().join("config/fastdds_large_data.xml"),
        )
        .env("PYTHONUNBUFFERED", "1");
    command
}

/// Runs `tests/ros/<script>` to its end (see [`rclpy_command`]).
pub fn run_rclpy(script: &str, domain: u16) -> Output {
    rclpy_command(script, domain)
        .output()
        .expect("cannot run python")
}

/// Runs `tests/ros/<script>` against `node` to its end and prints its output; fails the test,
/// with the script's outputs and the node's log, unless the script succeeds. Returns its
/// standard output.
pub fn run_rclpy_against(node: &NodeProcess, script: &str, domain: u16) -> String {
    let out = run_rclpy(script, domain);
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    println!("{stdout}");
    assert!(
        out.status.success(),
        "{script} failed:\n{stdout}\n{stderr}\n--- node log ---\n{}",
        node.log()
    );
    stdout
}
