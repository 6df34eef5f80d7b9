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
        .args(["bench", "scene", "--quick", "--plot", "/tmp/unused-plots"])
        .output()
        .expect("hardbody runs");
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("no plots"));
    assert!(!std::path::Path::new("/tmp/unused-plots").exists());
}

#[test]
fn superellipsoid_mc_compress_and_effects_suites_run_quick() {
    let dir = std::env::temp_dir().join(format!("hardbody-bench-quick2-{}", std::process::id()));
    let rows = bench("superellipsoid", &dir);
    check_rows("superellipsoid", &rows);
    for r in &rows {
        let (distances, iterations) = (
            r["distances_per_collision"].as_f64().unwrap(),
            r["iterations_per_distance"].as_f64().unwrap(),
        );
        // Every collision of a general pair is located by exact distances,
        // each at least one solver iteration.
        assert!(distances >= 1.0 && iterations >= 1.0, "{r}");
        assert!(r["exponent"].as_f64().is_some(), "{r}");
    }
    check_plot(
        &dir.join("superellipsoid-time.svg"),
        &["exponent p", "time per collision (us)", "X0 = 2"],
    );
    check_plot(
        &dir.join("superellipsoid-iterations.svg"),
        &["exponent p", "iterations per distance evaluation"],
    );

    let rows = bench("mc", &dir);
    let table = |name: &str| -> Vec<&serde_json::Value> {
        rows.iter().filter(|r| r["table"] == name).collect()
    };
    for r in table("speed").into_iter().chain(table("density")) {
        assert!(r["trial_moves_per_s"].as_f64().unwrap() > 1e4, "{r}");
    }
    // Acceptance falls as the moves grow, for every shape.
    let sizes = table("move size");
    assert!(!sizes.is_empty());
    for pair in sizes.windows(2) {
        if pair[0]["shape"] == pair[1]["shape"] {
            let (a, b) = (
                pair[0]["acceptance_translate"].as_f64().unwrap(),
                pair[1]["acceptance_translate"].as_f64().unwrap(),
            );
            assert!(
                b < a,
                "acceptance did not fall with the move size: {pair:?}"
            );
        }
    }
    check_plot(
        &dir.join("mc-moves-per-second.svg"),
        &["packing fraction", "trial moves per second", "ellipsoid"],
    );
    check_plot(
        &dir.join("mc-acceptance.svg"),
        &["move size", "fraction of moves accepted", "rotations"],
    );

    // Compression: every row reached its target, overlap-free (the suite
    // checks), in finite time; time against N for two shapes, plotted.
    let rows = bench("compress", &dir);
    let count = |t: &str| rows.iter().filter(|r| r["table"] == t).count();
    assert_eq!(
        (count("reference"), count("suite"), count("scaling")),
        (3, 5, 4)
    );
    for r in &rows {
        let phi = r["packing_fraction"].as_f64().unwrap();
        let seconds = r["seconds"].as_f64().unwrap();
        assert!((0.45 - 1e-9..=0.6 + 1e-9).contains(&phi), "{r}");
        assert!(seconds > 0.0 && seconds.is_finite(), "{r}");
        assert!(r["sweeps"].as_u64().unwrap() > 0, "{r}");
    }
    check_plot(
        &dir.join("compress-scaling.svg"),
        &["particles N", "time per particle", "Sphere"],
    );

    let rows = bench("effects", &dir);
    // Nine effects, true inertia for four shapes.
    assert_eq!(rows.len(), 12);
    for r in &rows {
        let (off, on) = (r["off_us"].as_f64().unwrap(), r["on_us"].as_f64().unwrap());
        assert!(
            off > 0.0 && on > 0.0 && off.is_finite() && on.is_finite(),
            "{r}"
        );
    }
    check_plot(
        &dir.join("effects.svg"),
        &[
            "time with the effect on / time with it off",
            "rotation",
            "walls",
        ],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}

/// The table suites run quick too: OCSI (with its plots), the scene path
/// against the library, the headline time-per-collision table and the
/// tolerance suite (with its plots and its verdict on ε_d).
#[test]
fn ocsi_scene_edmd_and_tolerance_suites_run_quick() {
    let dir = std::env::temp_dir().join(format!("hardbody-bench-quick3-{}", std::process::id()));
    let rows = bench("ocsi", &dir);
    assert!(rows.len() >= 7, "one row per algorithm and radius");
    for r in &rows {
        let ns = r["ns_per_test"].as_f64().unwrap();
        assert!(ns > 0.0 && ns < 1e4, "{r}");
    }
    check_plot(
        &dir.join("ocsi-L-R0.5.svg"),
        &["cuboid length L*", "time per test (ns)", "ocsi", "qrf"],
    );
    check_plot(&dir.join("ocsi-W-R5.svg"), &["cuboid width W*"]);

    let json = |suite: &str| -> Vec<serde_json::Value> {
        let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
            .args(["bench", suite, "--quick", "--json"])
            .output()
            .expect("hardbody runs");
        assert!(
            out.status.success(),
            "{suite}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        serde_json::from_slice(&out.stdout).expect("a JSON array of rows")
    };
    let rows = json("scene");
    assert!(!rows.is_empty());
    for r in &rows {
        assert!(r["us_per_collision"].as_f64().unwrap() > 0.0, "{r}");
    }
    let rows = json("edmd");
    check_rows("edmd", &rows);
    // The paper's Fig. 7 setting for both ellipsoids, cells and lists:
    // ε_d = 1e-5 and a shell of 0.15 smallest semi-axes.
    for (system, semi_axis) in [
        ("ellipsoids, aspect 2", 0.5),
        ("ellipsoids, aspect 0.5", 0.25),
    ] {
        let fig7: Vec<_> = rows
            .iter()
            .filter(|r| r["system"] == system && r["grazing_threshold"] == 1e-5)
            .collect();
        assert_eq!(fig7.len(), 2, "{system}: {fig7:?}");
        assert!(fig7.iter().any(|r| r["shell"].is_null()), "{system}");
        assert!(
            fig7.iter()
                .any(|r| (r["shell"].as_f64().unwrap_or(0.0) - 0.15 * semi_axis).abs() < 1e-12),
            "{system}: {fig7:?}"
        );
    }

    let rows = bench("edmd-tolerance", &dir);
    assert!(rows.iter().any(|r| r["reference"] == true));
    for r in &rows {
        assert!(
            r["missed"].is_null(),
            "a collision missed in the quick run: {r}"
        );
        assert!(r["us_per_collision"].as_f64().unwrap() > 0.0, "{r}");
    }
    check_plot(
        &dir.join("edmd-tolerance-grazing-time.svg"),
        &["grazing threshold", "time per collision (us)", "aspect 2"],
    );
    check_plot(
        &dir.join("edmd-tolerance-newton-error.svg"),
        &["Newton tolerance", "contact-time error"],
    );
    std::fs::remove_dir_all(&dir).unwrap();
}
