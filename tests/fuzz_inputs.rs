//! Fuzzed inputs (issue 19): arbitrary and mutated CDR payloads on every input topic, and
//! mutated and truncated shipped scene files. Never a panic; a payload either decodes or is
//! refused with a reason; a bad scene value is refused with its key named. Inputs come from a
//! fixed-seed generator, so a failure names the case that reproduces it.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;

use dvrk_tissue_sim::config;
use dvrk_tissue_sim::ros::inputs::input_topics;
use dvrk_tissue_sim::ros::msgs::*;

/// xorshift64*: a fixed sequence, independent of any crate.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Valid payloads of each input type, to mutate.
fn seeds() -> Vec<Vec<u8>> {
    let header = Header {
        stamp: Time::from_secs(1.5),
        frame_id: "PSM1_base".into(),
    };
    vec![
        to_cdr(&JointState {
            header: header.clone(),
            name: vec!["yaw".into(), "pitch".into()],
            position: vec![0.1, 0.2, 0.12, 0.0, 0.0, 0.0],
            velocity: vec![],
            effort: vec![1.0],
        })
        .unwrap(),
        to_cdr(&PoseStamped {
            header: header.clone(),
            ..Default::default()
        })
        .unwrap(),
        to_cdr(&WrenchStamped {
            header,
            ..Default::default()
        })
        .unwrap(),
        to_cdr(&Bool { data: true }).unwrap(),
        to_cdr(&StringMsg {
            data: "enable".into(),
        })
        .unwrap(),
    ]
}

fn mutate(rng: &mut Rng, seed: &[u8]) -> Vec<u8> {
    let mut bytes = seed.to_vec();
    match rng.below(5) {
        // Truncated anywhere.
        0 => bytes.truncate(rng.below(bytes.len() + 1)),
        // Random bytes flipped.
        1 => {
            for _ in 0..1 + rng.below(8) {
                let i = rng.below(bytes.len());
                if let Some(b) = bytes.get_mut(i) {
                    *b ^= 1 << rng.below(8);
                }
            }
        }
        // A length or count field set huge (a 4-byte word after the header).
        2 => {
            if bytes.len() >= 8 {
                let at = 4 + 4 * rng.below((bytes.len() - 4) / 4);
                let huge: u32 = [u32::MAX, 0x7fff_ffff, 1 << 28][rng.below(3)];
                if at + 4 <= bytes.len() {
                    bytes[at..at + 4].copy_from_slice(&huge.to_le_bytes());
                }
            }
        }
        // Entirely random, with a valid or random CDR header.
        3 => {
            let n = rng.below(256);
            bytes = (0..n).map(|_| rng.next() as u8).collect();
            if rng.below(2) == 0 && bytes.len() >= 4 {
                bytes[..4].copy_from_slice(&CDR_LE_HEADER);
            }
        }
        // Big-endian header on little-endian data, or garbage appended.
        _ => {
            if bytes.len() >= 2 {
                bytes[1] = 0x00;
            }
            bytes.extend((0..rng.below(64)).map(|_| rng.next() as u8));
        }
    }
    bytes
}

#[test]
fn fuzzed_cdr_payloads_on_every_input_topic_never_panic() {
    let scene =
        config::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("config/teleop.toml")).unwrap();
    let topics = input_topics(&scene, "/");
    assert!(topics.len() >= 10, "{} input topics", topics.len());
    let seeds = seeds();
    let mut rng = Rng(0x9e37_79b9_7f4a_7c15);
    let (mut decoded, mut refused) = (0u32, 0u32);
    for case in 0..20_000u32 {
        let topic = &topics[rng.below(topics.len())];
        let seed = &seeds[rng.below(seeds.len())];
        let payload = mutate(&mut rng, seed);
        let outcome = catch_unwind(AssertUnwindSafe(|| {
            match topic.kind.decode(&payload) {
                Ok(message) => {
                    // What the node does next with a decoded message: never a panic either.
                    let _ = topic.to_sim_input(message);
                    true
                }
                Err(e) => {
                    assert!(!e.to_string().is_empty());
                    false
                }
            }
        }));
        match outcome {
            Ok(true) => decoded += 1,
            Ok(false) => refused += 1,
            Err(_) => panic!(
                "case {case}: {} ({:?}) panicked on {} bytes {:02x?}",
                topic.topic,
                topic.kind,
                payload.len(),
                payload
            ),
        }
    }
    println!("20000 fuzzed payloads: {decoded} decoded, {refused} refused with a reason");
    assert!(decoded > 0 && refused > 0);
}

/// `key = value` lines of a scene file: (line index, key).
fn value_lines(text: &str) -> Vec<(usize, String)> {
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| {
            let (key, value) = l.split_once('=')?;
            let key = key.trim();
            let value = value.trim();
            let numeric = value
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_digit() || c == '-' || c == '[');
            (!key.is_empty() && !key.starts_with('#') && !key.contains(' ') && numeric)
                .then(|| (i, key.to_owned()))
        })
        .collect()
}

#[test]
fn mutated_and_truncated_shipped_scenes_never_panic_and_name_the_key() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut rng = Rng(0x51_7cc1_b727_220a);
    let mut refused = 0u32;
    let mut tried = 0u32;
    for name in ["default", "teleop", "retraction", "push", "needle"] {
        let path = root.join(format!("config/{name}.toml"));
        let text = std::fs::read_to_string(&path).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        // Every numeric value replaced by NaN, infinity, huge numbers, a negative, text.
        for (i, key) in value_lines(&text) {
            for bad in [
                "nan",
                "inf",
                "-inf",
                "1e308",
                "-1e308",
                "\"x\"",
                "[nan, 0.0, 0.0]",
            ] {
                let mut edited = lines.clone();
                let replaced = format!("{key} = {bad}");
                edited[i] = &replaced;
                let mutated = edited.join("\n");
                tried += 1;
                let result =
                    catch_unwind(|| config::from_str(&mutated, &path)).unwrap_or_else(|_| {
                        panic!("{name}.toml line {}: `{replaced}` panicked", i + 1)
                    });
                match result {
                    Ok(_) => {
                        // Accepted: only a value the key allows (a huge bound, a text name).
                        assert!(
                            !bad.contains("nan"),
                            "{name}.toml line {}: `{replaced}` accepted",
                            i + 1
                        );
                    }
                    Err(e) => {
                        refused += 1;
                        let message = e.to_string();
                        let leaf = key.rsplit('.').next().unwrap();
                        assert!(
                            message.contains(leaf),
                            "{name}.toml line {}: `{replaced}`: the error does not name {leaf}: \
                             {message}",
                            i + 1
                        );
                    }
                }
            }
        }
        // Truncated at random places.
        for _ in 0..200 {
            let cut = rng.below(text.len());
            let Some(truncated) = text.get(..cut) else {
                continue;
            };
            tried += 1;
            let result = catch_unwind(|| config::from_str(truncated, &path))
                .unwrap_or_else(|_| panic!("{name}.toml cut at byte {cut} panicked"));
            if let Err(e) = result {
                assert!(!e.to_string().is_empty());
            }
        }
    }
    println!("{tried} mutated scene files, {refused} value edits refused naming their key");
    assert!(refused > 100);
}
