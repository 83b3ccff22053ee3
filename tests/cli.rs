//! The command line as a user runs it.

mod support;

#[test]
fn headless_run_prints_frame_lines_and_a_summary() {
    let stdout = support::stdout_of_success(support::binary().args([
        "run",
        "--scene",
        "config/default.toml",
        "--headless",
        "--seconds",
        "0.05",
    ]));
    let frames: Vec<&str> = stdout.lines().filter(|l| l.starts_with("t=")).collect();
    assert_eq!(frames.len(), 3, "{stdout}");
    for line in &frames {
        for field in ["substeps=", "gripper F=(", "vmax=", "rtf="] {
            assert!(line.contains(field), "{line} lacks {field}");
        }
    }
    assert!(stdout.contains("M particle-substeps/s"), "{stdout}");
    assert!(stdout.contains("real-time factor"), "{stdout}");
}

#[test]
fn check_reports_bad_scene_with_key_value_and_range() {
    let dir = std::env::temp_dir().join(format!("dts-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/config/default.toml"))
        .unwrap()
        .replace("poisson_ratio = 0.45", "poisson_ratio = 0.55");
    std::fs::write(&bad, text).unwrap();
    let out = support::binary()
        .args(["check", "config/default.toml"])
        .arg(&bad)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success());
    assert!(stdout.contains("config/default.toml: ok"), "{stdout}");
    assert!(
        stdout.contains("bad.toml: 1 problem(s)")
            && stdout.contains("tissue[0].material.poisson_ratio = 0.55: 0 ≤ ν < 0.5"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn node_with_a_bad_namespace_fails_before_touching_the_network() {
    let out = support::binary()
        .args([
            "run",
            "--scene",
            "config/default.toml",
            "--namespace",
            "not a namespace",
        ])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("node name / namespace"), "{stderr}");
}

#[test]
fn snapshot_writes_a_png_of_the_scene() {
    let path = std::env::temp_dir().join(format!("dts-snapshot-{}.png", std::process::id()));
    let out = support::binary()
        .args([
            "snapshot",
            "--scene",
            "config/default.toml",
            "--time",
            "0.02",
            "--width",
            "160",
            "--height",
            "120",
            "--out",
        ])
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let decoder = png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&path).unwrap()));
    let mut reader = decoder.read_info().unwrap();
    let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut pixels).unwrap();
    assert_eq!((info.width, info.height), (160, 120));
    // The tissue shows in the colour map's dark purple end (unstrained), the tool in grey.
    let rgb: Vec<[u8; 3]> = pixels[..info.buffer_size()]
        .chunks(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let tissue = rgb
        .iter()
        .filter(|c| c[2] > c[1] + 40 && c[0] < 120)
        .count();
    assert!(
        tissue * 100 > rgb.len(),
        "only {tissue} tissue-coloured pixels of {}",
        rgb.len()
    );
    std::fs::remove_file(&path).ok();
}

#[test]
fn headless_run_writes_snapshots_at_the_asked_interval() {
    let dir = std::env::temp_dir().join(format!("dts-snapshots-{}", std::process::id()));
    let stdout = support::stdout_of_success(
        support::binary()
            .args([
                "run",
                "--scene",
                "config/default.toml",
                "--headless",
                "--seconds",
                "0.1",
                "--snapshot-every",
                "0.05",
                "--snapshot-dir",
            ])
            .arg(&dir),
    );
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert_eq!(names, ["t0000.050.png", "t0000.100.png"], "{stdout}");
    for name in &names {
        let file = std::fs::File::open(dir.join(name)).unwrap();
        let info = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .unwrap();
        assert_eq!((info.info().width, info.info().height), (960, 640));
        assert!(stdout.contains(name.as_str()), "{stdout}");
    }
    std::fs::remove_dir_all(&dir).ok();

    let bad = support::binary()
        .args(["run", "--headless", "--snapshot-every", "0"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--snapshot-every"));
}

#[test]
fn bench_frame_prints_a_row_per_backend_with_both_timings_and_writes_them() {
    let dir = std::env::temp_dir().join(format!("dts-bench-frame-{}", std::process::id()));
    let stdout = support::stdout_of_success(
        support::binary()
            .args(["bench", "frame", "--frames", "2", "--out"])
            .arg(&dir),
    );
    let rows = table_rows(&stdout, |backend| {
        backend == "cpu" || backend.starts_with("gpu-")
    });
    assert!(
        rows.iter().any(|r| r[0] == "cpu"),
        "no CPU row in\n{stdout}"
    );
    for r in &rows {
        assert_eq!(r[1], "24000", "seed-000 particle count: {r:?}");
        let serial: f64 = r[4].parse().unwrap();
        let cloud: f64 = r[5].parse().unwrap();
        let pipelined: f64 = r[6].parse().unwrap();
        assert!(serial > 0.0 && pipelined > 0.0, "{r:?}");
        assert!(cloud > 0.0 && cloud < serial, "{r:?}");
    }
    // The files: the provenance header, then the very rows printed.
    let md = std::fs::read_to_string(dir.join("frame.md")).unwrap();
    let csv = std::fs::read_to_string(dir.join("frame.csv")).unwrap();
    std::fs::remove_dir_all(&dir).ok();
    for key in ["command", "commit", "date", "machine"] {
        assert!(md.contains(&format!("- {key}: `")), "{md}");
        assert!(csv.contains(&format!("# {key}: ")), "{csv}");
    }
    assert!(md.contains("bench frame --frames 2 --out"), "{md}");
    assert!(md.contains(" cores, "), "{md}");
    let printed: Vec<&str> = stdout.lines().filter(|l| l.starts_with('|')).collect();
    let in_md: Vec<&str> = md.lines().filter(|l| l.starts_with('|')).collect();
    assert_eq!(in_md, printed);
    let in_csv: Vec<Vec<&str>> = csv
        .lines()
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(|l| l.split(',').collect())
        .collect();
    let printed_cells: Vec<Vec<&str>> = printed
        .iter()
        .filter(|l| !l.starts_with("|---"))
        .map(|l| table_cells(l))
        .collect();
    assert_eq!(in_csv, printed_cells, "{csv}");
}

/// `bench thread` ends with config/knot.toml stepped headless: its real-time factor on one
/// core, the knot's determinant, the largest strain and the frames the crossing guard acted
/// in. Two simulated seconds: the grippers have lifted the loop, no knot yet.
#[test]
fn bench_thread_times_the_knot_scene_on_one_core() {
    let dir = std::env::temp_dir().join(format!("dts-bench-thread-{}", std::process::id()));
    let stdout = support::stdout_of_success(
        support::binary()
            .args([
                "bench",
                "thread",
                "--frames",
                "2",
                "--knot-seconds",
                "2",
                "--out",
            ])
            .arg(&dir),
    );
    std::fs::remove_dir_all(&dir).ok();
    let rows = table_rows(&stdout, |scene| scene == "config/knot.toml");
    assert_eq!(rows.len(), 1, "one knot row in\n{stdout}");
    let r = &rows[0];
    assert_eq!(r[1], "2.00", "simulated seconds: {r:?}");
    let (wall, cpu, factor): (f64, f64, f64) = (
        r[2].parse().unwrap(),
        r[3].parse().unwrap(),
        r[4].parse().unwrap(),
    );
    assert!(wall > 0.0 && cpu > 0.0, "{r:?}");
    assert!(
        (factor - 2.0 / cpu).abs() < 0.02,
        "factor = simulated / cpu: {r:?}"
    );
    assert_eq!(r[5], "1", "unknotted at 2 s: {r:?}");
    let strain: f64 = r[6].parse().unwrap();
    assert!(strain < 1e-3, "the thread keeps its length: {r:?}");
    assert_eq!(r[7], "0", "nothing passed through: {r:?}");
}

/// The cells of a Markdown table row, trimmed.
fn table_cells(row: &str) -> Vec<&str> {
    row.trim()
        .trim_matches('|')
        .split('|')
        .map(str::trim)
        .collect()
}

/// The rows of the Markdown tables in `text` whose first cell `keep` accepts.
fn table_rows(text: &str, keep: impl Fn(&str) -> bool) -> Vec<Vec<&str>> {
    text.lines()
        .filter(|l| l.starts_with('|'))
        .map(table_cells)
        .filter(|cells| keep(cells[0]))
        .collect()
}

/// `bench camera` times the stereo frame at three resolutions and the simulation unsubscribed,
/// subscribed and recorded with and without the pictures; the bag of the last holds one
/// picture every other frame (30 Hz at 60 frames/s), as many as the subscribed run rendered;
/// on the GPU backend it times the tissue drawn in place against drawn from the host.
#[test]
fn bench_camera_times_the_frame_and_the_runs_with_and_without_pictures() {
    let dir = std::env::temp_dir().join(format!("dts-bench-camera-{}", std::process::id()));
    let stdout = support::stdout_of_success(
        support::binary()
            .args(["bench", "camera", "--scene", "tests/scenes/camera.toml"])
            .args(["--frames", "4", "--out"])
            .arg(&dir),
    );
    std::fs::remove_dir_all(&dir).ok();
    let frames = table_rows(&stdout, |eye| eye.contains(" × "));
    assert_eq!(frames.len(), 3, "{stdout}");
    for r in &frames {
        let render_ms: f64 = r[3].parse().unwrap();
        let jpeg_ms: f64 = r[4].parse().unwrap();
        assert!(render_ms > 0.0 && jpeg_ms > 0.0, "{r:?}");
    }
    let runs = table_rows(&stdout, |run| {
        run == "unsubscribed" || run == "subscribed" || run.starts_with("recorded")
    });
    let pictures: Vec<&str> = runs.iter().map(|r| r[2]).collect();
    assert_eq!(
        pictures,
        ["0", "2 rendered", "0", "2 in the bag"],
        "{stdout}"
    );
    for r in &runs {
        assert!(r[1].parse::<f64>().unwrap() > 0.0, "{r:?}");
    }
    // On the GPU backend (llvmpipe here) the tissue drawn in place and from the host.
    let drawn = table_rows(&stdout, |from| {
        from.starts_with("the solver's buffers") || from.starts_with("positions read back")
    });
    assert_eq!(drawn.len(), 2, "{stdout}");
    for r in &drawn {
        assert!(r[1].parse::<f64>().unwrap() > 0.0, "{r:?}");
        assert!(r[2].parse::<f64>().unwrap() > 0.0, "{r:?}");
    }
}

/// `bench throughput --threads` runs the seed-000 scene in a pool of each size and reports
/// speed-up and efficiency against the first; a pool of no threads is refused.
#[test]
fn bench_throughput_sweeps_thread_counts() {
    let dir = std::env::temp_dir().join(format!("dts-bench-threads-{}", std::process::id()));
    let stdout = support::stdout_of_success(
        support::binary()
            .args([
                "bench",
                "throughput",
                "--frames",
                "1",
                "--threads",
                "1,2",
                "--out",
            ])
            .arg(&dir),
    );
    std::fs::remove_dir_all(&dir).ok();
    let rows = table_rows(&stdout, |threads| threads == "1" || threads == "2");
    assert_eq!(rows.len(), 2, "{stdout}");
    assert_eq!((rows[0][0], rows[1][0]), ("1", "2"), "{stdout}");
    assert_eq!(
        rows[0][5], "1.00",
        "the first size is the reference: {stdout}"
    );
    for r in &rows {
        assert_eq!(r[1], "24000");
        let rate: f64 = r[4].parse().unwrap();
        let speed_up: f64 = r[5].parse().unwrap();
        let efficiency: f64 = r[6].parse().unwrap();
        assert!(rate > 0.0 && speed_up > 0.0, "{r:?}");
        let threads: f64 = r[0].parse().unwrap();
        assert!((efficiency - speed_up / threads).abs() < 0.011, "{r:?}");
    }
    let refused = support::binary()
        .args(["bench", "throughput", "--threads", "0"])
        .output()
        .unwrap();
    assert!(!refused.status.success());
    assert!(String::from_utf8_lossy(&refused.stderr).contains("--threads"));
}

/// `bench throughput --transfer` times the seed-000 scene on each G2P path named, the first
/// the reference of the speed-up column; a path that is not one is refused with the names.
#[test]
fn bench_throughput_compares_g2p_paths() {
    let dir = std::env::temp_dir().join(format!("dts-bench-transfer-{}", std::process::id()));
    let stdout = support::stdout_of_success(
        support::binary()
            .args([
                "bench",
                "throughput",
                "--frames",
                "1",
                "--transfer",
                "scalar,lanes4",
                "--out",
            ])
            .arg(&dir),
    );
    std::fs::remove_dir_all(&dir).ok();
    let rows = table_rows(&stdout, |path| path == "scalar" || path == "lanes4");
    assert_eq!(rows.len(), 2, "{stdout}");
    assert_eq!((rows[0][1], rows[1][1]), ("1", "4"), "lanes: {stdout}");
    assert_eq!(
        rows[0][6], "1.00",
        "the first path is the reference: {stdout}"
    );
    for r in &rows {
        assert_eq!(r[2], "24000");
        let rate: f64 = r[5].parse().unwrap();
        assert!(rate > 0.0, "{r:?}");
    }
    let refused = support::binary()
        .args(["bench", "throughput", "--transfer", "lanes3"])
        .output()
        .unwrap();
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(stderr.contains("lanes16"), "{stderr}");
}

/// `config/knot.toml` ties its knot by its last keyframe: a headless run without `--seconds`
/// must get there.
#[test]
fn the_knot_scene_script_ends_after_its_last_keyframe_and_the_settle_time() {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/config/knot.toml");
    let scene = dvrk_tissue_sim::config::load(std::path::Path::new(path)).unwrap();
    let last = scene
        .tools
        .iter()
        .flat_map(|t| &t.keyframes)
        .map(|k| k.t)
        .fold(f64::MIN, f64::max);
    assert_eq!(last, 16.65);
    assert_eq!(scene.settle_s, 0.5, "the default settle time");
    assert_eq!(scene.script_end_s(), Some(16.65 + 0.5));
}

#[test]
fn headless_run_without_seconds_runs_the_script_to_its_end() {
    let dir = std::env::temp_dir().join(format!("dts-script-end-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let probe = |settle: &str| {
        format!(
            "name = \"probe\"\n{settle}\n[domain]\norigin = [-0.02, -0.02, 0.0]\n\
             size = [0.04, 0.04, 0.04]\ndx = 0.004\n[[tool]]\nname = \"probe\"\n\
             shape = {{ type = \"sphere\", radius = 0.004 }}\n\
             [[tool.keyframe]]\nt = 0.0\nposition = [0.0, 0.0, 0.03]\n\
             [[tool.keyframe]]\nt = 0.05\nposition = [0.0, 0.0, 0.02]\n\
             [[tissue]]\nname = \"block\"\ncenter = [0.0, 0.0, 0.014]\n\
             size = [0.008, 0.008, 0.008]\nparticles_per_axis = 2\n[tissue.material]\n\
             model = \"neo_hookean\"\nyoungs_modulus = 5000.0\npoisson_ratio = 0.3\n\
             density = 1000.0\n"
        )
    };
    let scene = dir.join("probe.toml");
    std::fs::write(&scene, probe("settle_s = 0.05")).unwrap();
    let out = support::binary()
        .args(["run", "--headless", "--scene"])
        .arg(&scene)
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("running 0.1 s simulated (the last keyframe plus settle_s)"),
        "{stderr}"
    );
    assert!(
        stdout.contains("summary: 6 frames, 0.100 s simulated"),
        "{stdout}"
    );

    let bad = dir.join("bad.toml");
    std::fs::write(&bad, probe("settle_s = -1.0")).unwrap();
    let out = support::binary().arg("check").arg(&bad).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success());
    assert!(
        stdout.contains("settle_s = -1.0: simulated seconds after the last keyframe"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
