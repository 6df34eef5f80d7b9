//! The benchmark suites' quick variants run (issue 6: `--quick` in CI) and
//! produce what they promise: rows with finite times for cells and for
//! neighbour lists, and readable plots (SVG with title, axis labels with
//! units, legend).

use std::process::Command;

fn bench(suite: &str, dir: &std::path::Path) -> Vec<serde_json::Value> {
    let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["bench", suite, "--quick", "--json", "--plot"])
        .arg(dir)
        .output()
        .expect("hardbody runs");
    assert!(
        out.status.success(),
        "{suite}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("a JSON array of rows")
}

fn check_rows(suite: &str, rows: &[serde_json::Value]) {
    assert!(!rows.is_empty(), "{suite}: no rows");
    for r in rows {
        let median = r["median_us_per_collision"].as_f64().unwrap();
        let (lo, hi) = (
            r["min_us_per_collision"].as_f64().unwrap(),
            r["max_us_per_collision"].as_f64().unwrap(),
        );
        assert!(
            median.is_finite() && median > 0.0 && lo <= median && median <= hi,
            "{suite}: {r}"
        );
    }
    assert!(
        rows.iter().any(|r| r["shell"].is_null()),
        "{suite}: no cells row"
    );
    assert!(
        rows.iter().any(|r| r["shell"].as_f64().is_some()),
        "{suite}: no lists row"
    );
}

fn check_plot(path: &std::path::Path, texts: &[&str]) {
    let svg = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    for t in texts {
        assert!(svg.contains(t), "{}: {t:?} missing", path.display());
    }
}

#[test]
fn shell_density_and_elongation_suites_run_quick_with_plots() {
    let dir = std::env::temp_dir().join(format!("hardbody-bench-quick-{}", std::process::id()));
    let rows = bench("edmd-shell", &dir);
    check_rows("edmd-shell", &rows);
    check_plot(
        &dir.join("edmd-shell-time.svg"),
        &[
            "neighbour shell",
            "time per collision (us)",
            "hard spheres, phi 0.5",
        ],
    );
    check_plot(
        &dir.join("edmd-shell-optimum.svg"),
        &["packing fraction", "fastest shell"],
    );
    let rows = bench("edmd-density", &dir);
    check_rows("edmd-density", &rows);
    check_plot(
        &dir.join("edmd-density.svg"),
        &[
            "packing fraction",
            "time per collision (us)",
            "cells",
            "neighbour lists",
        ],
    );
    let rows = bench("edmd-elongation", &dir);
    check_rows("edmd-elongation", &rows);
    assert!(
        rows.iter().all(|r| r["aspect"].as_f64().is_some()),
        "edmd-elongation: a row without its aspect ratio"
    );
    check_plot(
        &dir.join("edmd-elongation-time.svg"),
        &[
            "aspect ratio",
            "time per collision (us)",
            "oriented-box lists",
            "cells",
        ],
    );
    check_plot(
        &dir.join("edmd-elongation-ratio.svg"),
        &["aspect ratio", "time with cells / time with lists"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn plots_are_refused_for_suites_without_them() {
    let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["bench", "ocsi", "--quick", "--plot", "/tmp/unused-plots"])
        .output()
        .expect("hardbody runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no plots"));
}
