//! Faults while recording, as a user meets them: a node killed with SIGKILL at a random
//! moment (its bag rebuilt with `bag recover`, counted by two standard readers against what
//! the log said was on disk), a disk that fills up during the run (cause named, simulation
//! going on, what was written readable, a clean exit), and record paths that cannot be
//! written (refused before the node starts, cause named), and the polite stops other than
//! Ctrl-C (SIGTERM, SIGHUP) finishing the bag as SIGINT does.
//!
//! The node tests start DDS participants and run only inside a loopback-only network
//! namespace (as tests/ros_node.rs; `.ci/run` makes one); elsewhere they print
//! `SKIPPED: <reason>` and pass, unless `CI` is set. The full-disk and read-only cases mount
//! a small tmpfs, which needs root.

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

mod support;
use support::dds::{network_prerequisites, python, skip_or_fail};
use support::root;

const SMALL: &str = "tests/scenes/small.toml";

fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("dvrk-bag-faults-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    dir.join(name)
}

fn sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .args(args)
        .output()
        .expect("cannot run the binary")
}

/// The node on the small scene recording to `bag`, its log (recorder at debug: one line per
/// completed chunk) in `log`.
fn start_node(domain: u16, bag: &Path, log: &Path, extra: &[&str]) -> Child {
    Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .args(["run", "--scene", SMALL, "--backend", "cpu", "--record"])
        .arg(bag)
        .args(extra)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env(
            "RUST_LOG",
            "info,dvrk_tissue_sim::ros::recorder=debug,rustdds=error,ros2_client=warn",
        )
        .env("NO_COLOR", "1")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(log).unwrap())
        .spawn()
        .expect("cannot start the node")
}

fn read_log(log: &Path) -> String {
    std::fs::read_to_string(log).unwrap_or_default()
}

/// Waits (at most `limit`) for `child` to exit.
fn wait_exit(child: &mut Child, limit: Duration) -> Option<std::process::ExitStatus> {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if let Ok(Some(status)) = child.try_wait() {
            return Some(status);
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    None
}

/// Waits (at most `limit`) until the log contains `text`.
fn wait_for_log(log: &Path, text: &str, limit: Duration) -> bool {
    let deadline = Instant::now() + limit;
    while Instant::now() < deadline {
        if read_log(log).contains(text) {
            return true;
        }
        std::thread::sleep(Duration::from_millis(100));
    }
    false
}

/// The last "bag chunk closed: N messages through t = T s" of a log: (N, T in ns).
fn last_chunk(log: &str) -> Option<(u64, u64)> {
    log.lines().rev().find_map(|l| {
        let rest = l.split("bag chunk closed: ").nth(1)?;
        let n: u64 = rest.split(' ').next()?.parse().ok()?;
        let t: f64 = rest
            .split("through t = ")
            .nth(1)?
            .split(' ')
            .next()?
            .parse()
            .ok()?;
        Some((n, (t * 1e9).round() as u64))
    })
}

/// Per reader (rosbags, mcap): (total messages, messages with log time <= `upto` ns, last
/// log time), from tests/ros/count_bag.py.
fn count_bag(bag: &Path, upto: u64) -> Vec<(String, u64, u64, u64)> {
    let o = Command::new(python())
        .arg(root().join("tests/ros/count_bag.py"))
        .arg(bag)
        .arg(upto.to_string())
        .output()
        .expect("cannot run python");
    let stdout = String::from_utf8_lossy(&o.stdout).into_owned();
    println!("{stdout}");
    assert!(
        o.status.success(),
        "standard readers refuse {}:\n{stdout}\n{}",
        bag.display(),
        String::from_utf8_lossy(&o.stderr)
    );
    let field = |line: &str, key: &str| -> u64 {
        line.split(&format!("{key}="))
            .nth(1)
            .and_then(|v| v.split(' ').next())
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("no {key} in {line}"))
    };
    let counts: Vec<_> = stdout
        .lines()
        .map(|l| {
            (
                l.split(' ').next().unwrap().to_owned(),
                field(l, "total"),
                field(l, "upto"),
                field(l, "last_ns"),
            )
        })
        .collect();
    assert_eq!(counts.len(), 2, "{stdout}");
    counts
}

/// A moment in [from, from + span) that differs from run to run.
fn random_moment(from: Duration, span: Duration) -> Duration {
    let nanos = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .unwrap()
        .subsec_nanos() as u64;
    from + Duration::from_nanos(nanos % span.as_nanos() as u64)
}

#[test]
fn a_killed_node_loses_at_most_the_open_chunk_and_bag_recover_rebuilds_the_rest() {
    if !network_prerequisites(true) {
        return;
    }
    let (bag, log) = (scratch("killed.mcap"), scratch("killed.log"));
    let mut node = start_node(43, &bag, &log, &[]);
    let after = random_moment(Duration::from_secs(3), Duration::from_secs(4));
    std::thread::sleep(after);
    node.kill().unwrap(); // SIGKILL
    node.wait().unwrap();
    let text = read_log(&log);
    println!("killed after {after:?}\n{text}");
    let (written, through) = last_chunk(&text).expect("no completed chunk logged");

    // What standard readers make of the file as the kill left it: not a finished bag.
    assert!(dvrk_tissue_sim::ros::recover::is_unfinished(&bag).unwrap());
    // A replay refuses it and names the way out.
    let o = sim(&[
        "run",
        "--scene",
        SMALL,
        "--headless",
        "--replay",
        bag.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("bag recover"), "{stderr}");

    let recovered = scratch("recovered.mcap");
    let o = sim(&[
        "bag",
        "recover",
        bag.to_str().unwrap(),
        recovered.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    println!("{stdout}");
    assert!(
        o.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&o.stderr)
    );
    for (reader, total, upto, last) in count_bag(&recovered, through) {
        // Every message the log reported on disk is back, with the times it had.
        assert!(
            upto >= written,
            "{reader}: {upto} messages through {through} ns, the log said {written}"
        );
        assert!(
            total >= upto && last >= through,
            "{reader}: {total}, {last}"
        );
    }
    // Refusing to overwrite: the rebuilt bag is never clobbered by a second run.
    let again = sim(&[
        "bag",
        "recover",
        bag.to_str().unwrap(),
        recovered.to_str().unwrap(),
    ]);
    assert!(!again.status.success());
    assert!(String::from_utf8_lossy(&again.stderr).contains("already exists"));
}

/// A tmpfs of `size` mounted at a fresh folder, unmounted when dropped; `None` (test
/// skipped, or failed under CI) without the right to mount.
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(name: &str, options: &str) -> Option<Tmpfs> {
        let dir = scratch(name);
        std::fs::create_dir_all(&dir).unwrap();
        let ok = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "tmpfs"])
            .arg(&dir)
            .status()
            .is_ok_and(|s| s.success());
        if !ok {
            skip_or_fail("cannot mount a tmpfs (needs root)");
            return None;
        }
        Some(Tmpfs(dir))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// The "N messages kept" of the recorder's error line.
fn kept_messages(log: &str) -> u64 {
    let line = log
        .lines()
        .find(|l| l.contains("recording to") && l.contains("stopped"))
        .unwrap_or_else(|| panic!("no stop line in\n{log}"));
    line.split("keeps the ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no kept count in {line}"))
}

#[test]
fn a_full_disk_stops_the_recording_with_its_cause_and_keeps_the_bag_readable() {
    if !network_prerequisites(true) {
        return;
    }
    // The small scene writes about 1.5 MB per simulated second: 2 MiB fill up in ~1.4 s.
    let Some(disk) = Tmpfs::mount("full", "size=2m") else {
        return;
    };
    // (a) With --seconds: the simulation runs on to its end after the disk is full.
    let (bag, log) = (disk.0.join("a.mcap"), scratch("full_a.log"));
    let mut node = start_node(44, &bag, &log, &["--seconds", "4"]);
    let status = wait_exit(&mut node, Duration::from_secs(60));
    let text = read_log(&log);
    println!("{text}");
    let status = status.expect("the node did not end after --seconds 4");
    assert!(status.success(), "exit {status:?}");
    assert!(text.contains("no space left on the device"), "{text}");
    assert!(text.contains("bag finished early"), "{text}");
    let finished_line = text.lines().find(|l| l.contains("bag finished early"));
    assert!(
        finished_line.is_some_and(|l| l.contains("WARN")),
        "the end of a recording cut short is a warning"
    );
    let kept = kept_messages(&text);
    assert!(kept > 100, "{kept} messages kept");
    for (reader, total, _, _) in count_bag(&bag, u64::MAX) {
        assert_eq!(total, kept, "{reader}");
    }
    std::fs::remove_file(&bag).unwrap();

    // (b) Ctrl-C after the disk filled up: a clean exit, the bag as readable.
    let (bag, log) = (disk.0.join("b.mcap"), scratch("full_b.log"));
    let mut node = start_node(44, &bag, &log, &[]);
    assert!(
        wait_for_log(&log, "stopped", Duration::from_secs(30)),
        "{}",
        read_log(&log)
    );
    std::thread::sleep(Duration::from_millis(500));
    let _ = Command::new("kill")
        .args(["-INT", &node.id().to_string()])
        .status();
    let status = wait_exit(&mut node, Duration::from_secs(10));
    let text = read_log(&log);
    println!("{text}");
    let status = status.expect("no exit within 10 s of SIGINT");
    assert!(status.success(), "exit {status:?}");
    assert!(!text.contains("panicked"), "{text}");
    let kept = kept_messages(&text);
    for (reader, total, _, _) in count_bag(&bag, u64::MAX) {
        assert_eq!(total, kept, "{reader}");
    }
}

#[test]
fn unwritable_record_paths_are_refused_before_the_node_starts_with_the_cause() {
    if !network_prerequisites(false) {
        return;
    }
    let run = |bag: &Path| {
        sim(&[
            "run",
            "--scene",
            SMALL,
            "--backend",
            "cpu",
            "--seconds",
            "0.1",
            "--record",
            bag.to_str().unwrap(),
        ])
    };
    let missing = scratch("no/such/folder/b.mcap");
    let o = run(&missing);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(
        stderr.contains("does not exist") && stderr.contains("no/such/folder"),
        "{stderr}"
    );
    assert!(
        !stderr.contains("node PSM") && !stderr.contains(" up:"),
        "{stderr}"
    );

    let Some(disk) = Tmpfs::mount("readonly", "size=1m,ro") else {
        return;
    };
    let o = run(&disk.0.join("b.mcap"));
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success());
    assert!(stderr.contains("read-only file system"), "{stderr}");
}

/// SIGTERM (systemd, `docker stop`, `kill`) and SIGHUP (a closed terminal) stop the node as
/// SIGINT does: exit 0, the bag finished with every message the log says it kept, readable
/// by both standard readers.
#[test]
fn sigterm_and_sighup_finish_the_bag_as_sigint_does() {
    if !network_prerequisites(true) {
        return;
    }
    for (signal, domain) in [("TERM", 45), ("HUP", 46)] {
        let bag = scratch(&format!("{signal}.mcap"));
        let log = scratch(&format!("{signal}.log"));
        let mut node = start_node(domain, &bag, &log, &[]);
        assert!(
            wait_for_log(&log, "bag chunk closed", Duration::from_secs(30)),
            "SIG{signal}: no chunk recorded\n{}",
            read_log(&log)
        );
        let _ = Command::new("kill")
            .args([&format!("-{signal}"), &node.id().to_string()])
            .status();
        let status = wait_exit(&mut node, Duration::from_secs(10));
        let text = read_log(&log);
        let status = status.unwrap_or_else(|| {
            let _ = node.kill();
            panic!("no exit within 10 s of SIG{signal}\n{text}")
        });
        assert!(status.success(), "SIG{signal}: exit {status:?}\n{text}");
        assert!(
            text.contains(&format!("SIG{signal}: shutting down")),
            "SIG{signal} not named in the log\n{text}"
        );
        let finished = text
            .lines()
            .find_map(|l| l.split("bag finished: ").nth(1))
            .unwrap_or_else(|| panic!("SIG{signal}: no 'bag finished' line\n{text}"));
        // "<path>: N messages on ..."
        let kept: u64 = finished
            .split(" messages on ")
            .next()
            .and_then(|head| head.rsplit(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("no message count in '{finished}'"));
        assert!(kept > 0, "SIG{signal}: {finished}");
        for (reader, total, _, _) in count_bag(&bag, u64::MAX) {
            assert_eq!(total, kept, "SIG{signal}: {reader}");
        }
        std::fs::remove_file(&bag).unwrap();
    }
}

/// A 61-byte MCAP file whose second record claims `claimed` bytes: the header record (profile
/// `ros2`), then a Schema record's opcode and length, then a few bytes of it.
fn hostile_bag(path: &Path, claimed: u64) {
    let mut bytes = b"\x89MCAP0\r\n".to_vec();
    bytes.push(0x01);
    bytes.extend_from_slice(&12u64.to_le_bytes());
    bytes.extend_from_slice(&4u32.to_le_bytes());
    bytes.extend_from_slice(b"ros2");
    bytes.extend_from_slice(&0u32.to_le_bytes());
    bytes.push(0x03);
    bytes.extend_from_slice(&claimed.to_le_bytes());
    bytes.resize(61, 0);
    std::fs::write(path, bytes).unwrap();
}

/// Runs the binary to its end and returns its output and its peak resident memory (bytes),
/// read from the kernel's accounting of that one child (wait4).
// The child is reaped by wait4 (which gives its rusage), not by `Child::wait`.
#[allow(clippy::zombie_processes)]
fn sim_with_peak_memory(args: &[&str]) -> (Output, u64) {
    let child = Command::new(env!("CARGO_BIN_EXE_dvrk-tissue-sim"))
        .current_dir(root())
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("cannot run the binary");
    let pid = child.id() as libc::pid_t;
    let (mut out, mut err) = (child.stdout.unwrap(), child.stderr.unwrap());
    let readers = (
        std::thread::spawn(move || {
            let mut b = Vec::new();
            std::io::Read::read_to_end(&mut out, &mut b).unwrap();
            b
        }),
        std::thread::spawn(move || {
            let mut b = Vec::new();
            std::io::Read::read_to_end(&mut err, &mut b).unwrap();
            b
        }),
    );
    let mut status = 0;
    // SAFETY: a zeroed rusage is a valid value for wait4 to fill in.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    // SAFETY: `pid` is our own child, not waited for elsewhere; both pointers are valid.
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4 failed");
    let output = Output {
        status: std::os::unix::process::ExitStatusExt::from_raw(status),
        stdout: readers.0.join().unwrap(),
        stderr: readers.1.join().unwrap(),
    };
    (output, usage.ru_maxrss as u64 * 1024)
}

/// Files named like `bag recover`'s partial output left in `dir`.
fn partial_outputs(dir: &Path) -> Vec<PathBuf> {
    std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.to_string_lossy().contains(".bag-recover-"))
        .collect()
}

/// Record lengths a hostile file claims (1.5 GiB, 1 TiB, 2⁶⁴ − 1) are refused before anything
/// is allocated for them, by `bag recover` and by `--replay`: a clean error or a bag of what
/// was readable, no panic, memory bounded, and no partial output left behind.
#[test]
fn hostile_record_lengths_are_refused_without_allocating_them() {
    let dir = scratch("hostile");
    std::fs::create_dir_all(&dir).unwrap();
    for claimed in [3u64 << 29, 1 << 40, u64::MAX] {
        let bag = dir.join(format!("claims_{claimed}.mcap"));
        hostile_bag(&bag, claimed);
        let out = dir.join(format!("recovered_{claimed}.mcap"));
        let (o, peak) = sim_with_peak_memory(&[
            "bag",
            "recover",
            bag.to_str().unwrap(),
            out.to_str().unwrap(),
        ]);
        let text = format!(
            "{}{}",
            String::from_utf8_lossy(&o.stdout),
            String::from_utf8_lossy(&o.stderr)
        );
        println!("recover, {claimed} bytes claimed: peak {peak} B\n{text}");
        assert!(!text.contains("panicked"), "{text}");
        assert!(o.status.code().is_some(), "killed by a signal: {text}");
        assert!(
            peak < 200 << 20,
            "peak memory {peak} B for {claimed} claimed"
        );
        assert!(
            text.contains("too large") || text.contains("cut off"),
            "the refusal is not named: {text}"
        );
        assert!(
            partial_outputs(&dir).is_empty(),
            "{:?}",
            partial_outputs(&dir)
        );

        let (o, peak) = sim_with_peak_memory(&[
            "run",
            "--headless",
            "--scene",
            SMALL,
            "--backend",
            "cpu",
            "--replay",
            bag.to_str().unwrap(),
        ]);
        let stderr = String::from_utf8_lossy(&o.stderr);
        println!("replay, {claimed} bytes claimed: peak {peak} B\n{stderr}");
        assert_eq!(o.status.code(), Some(1), "{stderr}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert!(stderr.contains(bag.to_str().unwrap()), "{stderr}");
        assert!(
            peak < 200 << 20,
            "peak memory {peak} B for {claimed} claimed"
        );
    }
}

/// `--record` and `bag recover` never overwrite a file or write through a symlink unless
/// told to (`--force`), and then replace the link, not its target; a failed `bag recover`
/// leaves nothing behind.
#[test]
fn record_and_recover_outputs_are_created_new_and_never_through_a_symlink() {
    let dir = scratch("create_new");
    std::fs::create_dir_all(&dir).unwrap();
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "precious").unwrap();
    let link = dir.join("planted.mcap");
    std::os::unix::fs::symlink(&victim, &link).unwrap();
    let record = |bag: &Path, force: bool| {
        let mut args = vec![
            "run",
            "--headless",
            "--scene",
            SMALL,
            "--backend",
            "cpu",
            "--seconds",
            "0.1",
            "--record",
            bag.to_str().unwrap(),
        ];
        if force {
            args.push("--force");
        }
        sim(&args)
    };

    // An existing file and a planted symlink are refused, and stay as they were.
    let existing = dir.join("existing.mcap");
    std::fs::write(&existing, "mine").unwrap();
    for path in [&existing, &link] {
        let o = record(path, false);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert!(!o.status.success(), "{stderr}");
        assert!(
            stderr.contains("already exists") && stderr.contains("--force"),
            "{stderr}"
        );
    }
    assert_eq!(std::fs::read_to_string(&existing).unwrap(), "mine");
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");

    // --force replaces the link itself: the victim is untouched, the bag is readable.
    let o = record(&link, true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");
    let recovered = |input: &Path, output: &Path, force: bool| {
        let mut args = vec![
            "bag",
            "recover",
            input.to_str().unwrap(),
            output.to_str().unwrap(),
        ];
        if force {
            args.push("--force");
        }
        sim(&args)
    };

    // bag recover: a dangling symlink at the output is refused too, with or without a
    // target; with --force it is replaced by the bag.
    let dangling = dir.join("dangling.mcap");
    std::os::unix::fs::symlink(dir.join("nowhere"), &dangling).unwrap();
    let o = recovered(&link, &dangling, false);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(!o.status.success(), "{stderr}");
    assert!(stderr.contains("already exists"), "{stderr}");
    assert!(!dir.join("nowhere").exists());
    let o = recovered(&link, &dangling, true);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(!dir.join("nowhere").exists());
    assert!(std::fs::symlink_metadata(&dangling).unwrap().is_file());

    // A failed recovery (the input is not a bag) leaves no output and no partial file.
    let failed = dir.join("failed.mcap");
    let o = recovered(&victim, &failed, false);
    assert!(!o.status.success());
    assert!(!failed.exists());
    assert!(
        partial_outputs(&dir).is_empty(),
        "{:?}",
        partial_outputs(&dir)
    );
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "precious");
}
