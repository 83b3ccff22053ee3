//! What another process on the network can do to the node through DDS itself (issue 39):
//! raw RTPS packets claiming huge fragmented samples from made-up writers, and a second
//! node started under the first one's name.
//!
//! Starts DDS participants: runs only inside a loopback-only network namespace (as
//! tests/ros_node.rs; `.ci/run` makes one); elsewhere prints `SKIPPED: <reason>` and passes,
//! unless `CI` is set.

use std::net::{Ipv4Addr, UdpSocket};
use std::process::Stdio;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

mod support;
use support::dds::network_prerequisites;
use support::node::{rclpy_command, NodeProcess};

const SMALL: [&str; 4] = ["--scene", "tests/scenes/small.toml", "--backend", "cpu"];

/// The flood test compares the node's frame rate with its own: its nodes run alone.
fn one_at_a_time() -> MutexGuard<'static, ()> {
    static NODES: Mutex<()> = Mutex::new(());
    NODES
        .lock()
        .unwrap_or_else(|poisoned| poisoned.into_inner())
}

/// A field of /proc/PID/status in kB (`VmRSS`, `VmSize`); 0 once the process is gone.
fn status_kb(pid: u32, field: &str) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with(field) && l[field.len()..].starts_with(':'))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse().ok())
        .unwrap_or(0)
}

/// One RTPS message from the made-up participant `prefix`: a DATA_FRAG for `reader` from
/// writer `writer` saying its sample is `claimed` bytes, with its first fragment
/// (`fragment` bytes of payload).
fn data_frag(
    prefix: [u8; 12],
    reader: [u8; 4],
    writer: [u8; 4],
    claimed: u32,
    fragment: u16,
) -> Vec<u8> {
    let mut m = Vec::new();
    m.extend_from_slice(b"RTPS");
    m.extend_from_slice(&[2, 3, 0x01, 0x0f]); // version 2.3, a vendor id
    m.extend_from_slice(&prefix);
    m.push(0x16); // DATA_FRAG
    m.push(0x01); // little endian
    let body_len = 4 + 28 + usize::from(fragment);
    m.extend_from_slice(&(body_len as u16).to_le_bytes());
    m.extend_from_slice(&0u16.to_le_bytes()); // extra flags
    m.extend_from_slice(&28u16.to_le_bytes()); // octets to inline QoS
    m.extend_from_slice(&reader);
    m.extend_from_slice(&writer);
    m.extend_from_slice(&0i32.to_le_bytes()); // sequence number, high
    m.extend_from_slice(&1u32.to_le_bytes()); // sequence number, low
    m.extend_from_slice(&1u32.to_le_bytes()); // fragment starting number
    m.extend_from_slice(&1u16.to_le_bytes()); // fragments in this submessage
    m.extend_from_slice(&fragment.to_le_bytes()); // fragment size
    m.extend_from_slice(&claimed.to_le_bytes()); // sample size
    m.extend_from_slice(&[0x00, 0x03, 0x00, 0x00]); // CDR_LE encapsulation
    m.resize(m.len() + usize::from(fragment) - 4, 0xab);
    m
}

/// Counts the node's /clock messages over `seconds` with rclpy (see tests/ros/count_clock.py).
fn spawn_clock_count(seconds: f64, domain: u16) -> std::process::Child {
    spawn_clock_count_waiting(seconds, 20.0, domain)
}

/// As [`spawn_clock_count`], giving up after `wait` seconds without a first message.
fn spawn_clock_count_waiting(seconds: f64, wait: f64, domain: u16) -> std::process::Child {
    rclpy_command("count_clock.py", domain)
        .arg(seconds.to_string())
        .arg(wait.to_string())
        .stdout(Stdio::piped())
        .spawn()
        .expect("cannot run python")
}

fn clock_count(child: std::process::Child) -> u64 {
    let out = child.wait_with_output().expect("count_clock.py");
    let text = String::from_utf8_lossy(&out.stdout);
    text.lines()
        .find_map(|l| l.strip_prefix("CLOCK "))
        .and_then(|n| n.trim().parse().ok())
        .unwrap_or_else(|| panic!("count_clock.py said: {text}"))
}

#[test]
fn data_frag_claims_from_made_up_writers_leave_memory_bounded_and_the_node_publishing() {
    let _one_at_a_time = one_at_a_time();
    if !network_prerequisites(true) {
        return;
    }
    let domain = 81u16;
    let node = NodeProcess::start_with(&SMALL, domain);
    let pid = node.pid();
    // Discovery (multicast and the first participant's unicast port) and user traffic
    // ports of `domain` (RTPS 9.6.1.1: PB 7400, DG 250, d0 0, d1 10, d3 11, PG 2).
    let base = 7400 + 250 * domain;
    let ports = [base, base + 10, base + 11];
    let spdp_reader = [0x00, 0x01, 0x00, 0xc7];
    let sedp_publications_reader = [0x00, 0x00, 0x03, 0xc7];
    let sedp_subscriptions_reader = [0x00, 0x00, 0x04, 0xc7];
    let readers = [
        spdp_reader,
        sedp_publications_reader,
        sedp_subscriptions_reader,
    ];

    // The node is up once its memory settles; then each packet comes from a new
    // participant and writer, to every port and reader.
    std::thread::sleep(Duration::from_secs(3));
    let rss = |pid| status_kb(pid, "VmRSS");
    let virtual_kb = |pid| status_kb(pid, "VmSize");
    let (rss_before, virtual_before) = (rss(pid), virtual_kb(pid));
    assert!(rss_before > 0, "the node did not start:\n{}", node.log());
    let counter = spawn_clock_count(3.0, domain);
    let socket = UdpSocket::bind("127.0.0.1:0").unwrap();
    let mut sent = 0u32;
    let (mut rss_peak, mut virtual_peak) = (rss_before, virtual_before);
    // 4 GiB claims (RustDDS 0.15.1 reserves each: 9 packets took 36 GiB of address
    // space), then claims under the node's limit whose sum the total bound must hold
    // (unbounded, 2,700 of them took 30 MB).
    let phases = [(u32::MAX, 100u32), (60 * 1024, 600)];
    let started = Instant::now();
    for (phase, (claimed, rounds)) in phases.into_iter().enumerate() {
        for round in 0..rounds {
            for (i, port) in ports.iter().enumerate() {
                for reader in readers {
                    let mut prefix = [0u8; 12];
                    prefix[..4].copy_from_slice(&round.to_le_bytes());
                    prefix[4] = i as u8;
                    prefix[5] = reader[2];
                    prefix[6] = phase as u8;
                    prefix[11] = 0x5a;
                    let writer = [prefix[0], prefix[1], 0x01, 0x02];
                    let packet = data_frag(prefix, reader, writer, claimed, 1024);
                    if socket.send_to(&packet, ("127.0.0.1", *port)).is_ok() {
                        sent += 1;
                    }
                }
            }
            if round % 5 == 0 {
                rss_peak = rss_peak.max(rss(pid));
                virtual_peak = virtual_peak.max(virtual_kb(pid));
                std::thread::sleep(Duration::from_millis(1));
            }
        }
    }
    let flood_s = started.elapsed().as_secs_f64();
    let clocks = clock_count(counter);
    rss_peak = rss_peak.max(rss(pid));
    virtual_peak = virtual_peak.max(virtual_kb(pid));
    let alive = rss(pid) > 0;
    let (status, log) = node.stop();
    eprintln!(
        "{sent} DATA_FRAG packets in {flood_s:.2} s; RSS {rss_before} kB before, peak \
         {rss_peak} kB; address space {virtual_before} kB before, peak {virtual_peak} kB; \
         {clocks} /clock messages in 3 s from the flood's start"
    );
    assert!(alive, "the node died under the flood:\n{log}");
    assert!(
        virtual_peak < virtual_before + 1024 * 1024,
        "address space rose from {virtual_before} kB to {virtual_peak} kB"
    );
    assert!(
        rss_peak < rss_before + 16 * 1024,
        "RSS rose from {rss_before} kB to {rss_peak} kB under {sent} DATA_FRAG packets"
    );
    // 60 frames/s: publishing at well over half its rate through the flood.
    assert!(clocks >= 90, "{clocks} /clock messages in 3 s:\n{log}");
    assert_eq!(status.and_then(|s| s.code()), Some(0), "{log}");
}

#[test]
fn a_second_node_with_the_same_name_is_refused_and_the_first_runs_on() {
    let _one_at_a_time = one_at_a_time();
    if !network_prerequisites(false) {
        return;
    }
    let domain = 82u16;
    let first = NodeProcess::start_with(&SMALL, domain);
    std::thread::sleep(Duration::from_secs(2));
    let started = Instant::now();
    let second = support::binary()
        .arg("run")
        .args(SMALL)
        .env("ROS_DOMAIN_ID", domain.to_string())
        .env("NO_COLOR", "1")
        .output()
        .expect("cannot start the second node");
    let refused_in = started.elapsed();
    let second_log = String::from_utf8_lossy(&second.stderr);
    let first_alive = status_kb(first.pid(), "VmRSS") > 0;
    let (status, first_log) = first.stop();
    eprintln!("second node refused in {refused_in:.2?}");
    assert_eq!(second.status.code(), Some(1), "{second_log}");
    assert!(
        second_log.contains("a node named /dvrk_tissue_sim already runs in this ROS domain"),
        "{second_log}"
    );
    assert!(first_alive, "the first node stopped:\n{first_log}");
    assert_eq!(status.and_then(|s| s.code()), Some(0), "{first_log}");
    assert!(!first_log.contains("already runs"), "{first_log}");
}

#[test]
fn an_unknown_discovery_range_is_refused_with_its_value() {
    if !network_prerequisites(false) {
        return;
    }
    let out = support::binary()
        .arg("run")
        .args(SMALL)
        .env("ROS_DOMAIN_ID", "83")
        .env("ROS_AUTOMATIC_DISCOVERY_RANGE", "NEIGHBOURS")
        .output()
        .expect("the binary runs");
    let log = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{log}");
    assert!(
        log.contains("ROS_AUTOMATIC_DISCOVERY_RANGE = \"NEIGHBOURS\": expected SUBNET, LOCALHOST"),
        "{log}"
    );
}

/// The local address and port of every UDP socket process `pid` holds (from `/proc`).
fn udp_sockets_of(pid: u32) -> Vec<(Ipv4Addr, u16)> {
    let inodes: Vec<String> = std::fs::read_dir(format!("/proc/{pid}/fd"))
        .expect("the node's file descriptors")
        .filter_map(|fd| std::fs::read_link(fd.ok()?.path()).ok())
        .filter_map(|target| {
            let target = target.to_string_lossy().into_owned();
            Some(
                target
                    .strip_prefix("socket:[")?
                    .strip_suffix(']')?
                    .to_owned(),
            )
        })
        .collect();
    let table = std::fs::read_to_string(format!("/proc/{pid}/net/udp")).expect("the UDP table");
    table
        .lines()
        .skip(1)
        .filter_map(|line| {
            let fields: Vec<&str> = line.split_whitespace().collect();
            let inode = *fields.get(9)?;
            if !inodes.iter().any(|i| i == inode) {
                return None;
            }
            let (ip, port) = fields.get(1)?.split_once(':')?;
            // The kernel prints the network-order address word as a native integer.
            let ip = Ipv4Addr::from(u32::from_be(u32::from_str_radix(ip, 16).ok()?));
            Some((ip, u16::from_str_radix(port, 16).ok()?))
        })
        .collect()
}

#[test]
fn discovery_range_localhost_is_found_on_this_host_and_off_by_nobody() {
    if !network_prerequisites(true) {
        return;
    }
    let _one_at_a_time = one_at_a_time();
    for (range, domain, found) in [("LOCALHOST", 84u16, true), ("OFF", 85, false)] {
        let node = support::binary()
            .args(["run", "--seconds", "10"])
            .args(SMALL)
            .env("ROS_DOMAIN_ID", domain.to_string())
            .env("ROS_AUTOMATIC_DISCOVERY_RANGE", range)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("cannot start the node");
        let clocks = clock_count(spawn_clock_count_waiting(1.0, 5.0, domain));
        let mut node = node;
        if range == "LOCALHOST" {
            let bound = udp_sockets_of(node.id());
            eprintln!("LOCALHOST: the node's UDP sockets are bound to {bound:?}");
            assert!(bound.len() >= 4, "the node's UDP sockets: {bound:?}");
            assert!(
                bound
                    .iter()
                    .all(|(ip, _)| *ip == Ipv4Addr::LOCALHOST
                        || *ip == Ipv4Addr::new(239, 255, 0, 1)),
                "LOCALHOST: every socket on loopback or the multicast group, none on every \
                 interface: {bound:?}"
            );
        }
        let _ = node.kill();
        let _ = node.wait();
        eprintln!("ROS_AUTOMATIC_DISCOVERY_RANGE={range}: {clocks} /clock messages in 1 s");
        assert_eq!(clocks > 0, found, "{range}: {clocks} /clock messages");
    }
}
