//! `stress --reduced` as CI runs it: every case of the reduced matrix (all inside the safe
//! envelope) stays stable, and the table reports each of them. No timing is asserted.

mod support;

#[test]
fn reduced_stress_matrix_is_stable() {
    let out_dir = std::env::temp_dir().join(format!("dvrk-stress-reduced-{}", std::process::id()));
    let (_, log) = support::output_of_success(
        support::binary()
            .args(["stress", "--reduced", "--backend", "cpu", "--out"])
            .arg(&out_dir),
    );
    let table = std::fs::read_to_string(out_dir.join("stress.md")).unwrap();
    let _ = std::fs::remove_dir_all(&out_dir);
    let rows: Vec<Vec<&str>> = table
        .lines()
        .filter(|l| l.starts_with('|'))
        .skip(2)
        .map(|l| l.trim_matches('|').split('|').map(str::trim).collect())
        .collect();
    // The cases the matrix ran, as the run reports each on its standard error when it
    // finishes ("group / case: stable (1.2 s)"): the table has a row for each, in order.
    let ran: Vec<(&str, &str)> = log
        .lines()
        .filter_map(|l| {
            let (case, verdict) = l.rsplit_once(": ")?;
            let reported = verdict.starts_with("stable (") || verdict.starts_with("UNSTABLE (");
            reported.then(|| case.split_once(" / "))?
        })
        .collect();
    assert!(!ran.is_empty(), "no case reported\n{log}");
    let named: Vec<(&str, &str)> = rows.iter().map(|r| (r[0], r[1])).collect();
    assert_eq!(named, ran, "{table}\n{log}");
    for group in [
        "material",
        "time step",
        "tool speed",
        "pb-mpm",
        "scenario",
        "soak",
        "implicit",
    ] {
        assert!(
            rows.iter().any(|r| r[0] == group),
            "{group} missing\n{table}"
        );
    }
    for r in &rows {
        assert_eq!(r[3], "yes", "{r:?}");
        let non_finite: usize = r[12].parse().unwrap();
        assert_eq!(non_finite, 0, "{r:?}");
        let penetration: f64 = r[10].parse().unwrap();
        assert!(penetration <= 2.0, "{r:?}");
    }
    // The 4× CFL case must show the step being cut; the 0.5× case must not.
    let subdivided = |name: &str| -> u32 {
        rows.iter().find(|r| r[1] == name).unwrap()[7]
            .parse()
            .unwrap()
    };
    assert!(subdivided("dt 4× CFL") > 0, "{table}");
    assert_eq!(subdivided("dt 0.5× CFL"), 0, "{table}");
}
