//! `bench --quick` as CI runs it: every explicit run at the coarse resolutions within its
//! error bound, and the CSV, Markdown and PNG written. No timing is asserted.

mod support;

use std::collections::BTreeSet;

#[test]
fn quick_bench_meets_error_bounds_and_writes_its_files() {
    let out_dir = std::env::temp_dir().join(format!("dvrk-bench-quick-{}", std::process::id()));
    support::stdout_of_success(
        support::binary()
            .args(["bench", "--quick", "--backends", "cpu", "--out"])
            .arg(&out_dir),
    );
    let csv = std::fs::read_to_string(out_dir.join("bench.csv")).unwrap();
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let column = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = lines.map(|l| l.split(',').collect()).collect();
    // The quick plan (its size is pinned beside it, in `SweepPlan::quick`'s unit test) is every
    // analytic case under every explicit solver setting: the rows are that grid, each run once.
    let case_columns = [
        column("scene"),
        column("resolution_cells"),
        column("backend"),
    ];
    let setting_columns = [column("solver"), column("step")];
    let case = |r: &Vec<&str>| pick(r, &case_columns);
    let setting = |r: &Vec<&str>| pick(r, &setting_columns);
    let cases: BTreeSet<_> = rows.iter().map(case).collect();
    let settings: BTreeSet<_> = rows.iter().map(setting).collect();
    let runs: BTreeSet<_> = rows.iter().map(|r| (case(r), setting(r))).collect();
    assert_eq!(runs.len(), rows.len(), "a run listed twice\n{csv}");
    assert_eq!(rows.len(), cases.len() * settings.len(), "{csv}");
    for r in &rows {
        assert!(
            r[column("solver")] != "implicit" && !r[column("scene")].contains("-stiff-"),
            "the implicit and stiff rows belong to the full bench: {r:?}"
        );
    }
    assert!(
        rows.iter().any(|r| r[column("solver")] == "PB-MPM"),
        "{csv}"
    );
    assert!(
        rows.iter().any(|r| r[column("solver")] == "PIC-MPM"),
        "{csv}"
    );
    for scene in ["hertz", "bar", "stretch"] {
        assert!(rows.iter().any(|r| r[column("scene")] == scene), "{csv}");
    }
    for r in &rows {
        let error: f64 = r[column("relative_error")].parse().unwrap();
        let bound: f64 = r[column("error_bound")].parse().unwrap();
        assert!(error.is_finite() && error.abs() <= bound, "{r:?}");
        let substeps: u64 = r[column("substeps")].parse().unwrap();
        assert!(substeps > 0, "{r:?}");
    }
    let md = std::fs::read_to_string(out_dir.join("bench.md")).unwrap();
    for key in ["command", "commit", "date", "machine"] {
        assert!(
            md.starts_with("- command: `") && md.contains(&format!("- {key}: `")),
            "{md}"
        );
        assert!(csv.contains(&format!("# {key}: ")), "{csv}");
    }
    assert_eq!(
        md.lines().filter(|l| l.starts_with('|')).count(),
        2 + rows.len()
    );
    let png = std::fs::read(out_dir.join("bench.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let _ = std::fs::remove_dir_all(&out_dir);
}

/// The fields of `row` in `columns`.
fn pick(row: &[&str], columns: &[usize]) -> Vec<String> {
    columns.iter().map(|&c| row[c].to_owned()).collect()
}
