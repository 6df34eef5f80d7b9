//! `hardbody analyze LOG --packing` on a packing jammed by compression:
//! the contact network of a random jammed packing of spheres is nearly
//! isostatic (a mean contact number of the backbone near 2 d_f = 6) with
//! a few per cent rattlers and no overlap, and a gap tolerance below the
//! packing's own gaps finds too few contacts to hold anything.

use std::process::Command;

const JAMMED: &str = r#"Scene(
    seed: 5,
    box: (12.0, 12.0, 12.0),
    species: [Species(name: "ball", shape: Sphere(radius: 0.5), count: 343)],
    start: Lattice,
    stages: [Compress(packing_fraction: 0.74, until_jammed: true)],
    log: Log(path: "jammed.mcap", stats_every: 100, frames_every: 5000),
)"#;

fn analyze(log: &std::path::Path, gap: &str) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["analyze", "--packing", "--json", "--gap", gap])
        .arg(log)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn a_jammed_sphere_packing_is_nearly_isostatic() {
    let dir = std::env::temp_dir().join(format!("hardbody-packing-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("jammed.ron");
    std::fs::write(&scene, JAMMED).unwrap();
    let log = dir.join("jammed.mcap");
    let run = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&log)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    let network = analyze(&log, "1e-2");
    let n = network["bodies"].as_u64().unwrap() as f64;
    let phi = network["packing_fraction"].as_f64().unwrap();
    let z = network["backbone_contact_number"].as_f64().unwrap();
    let rattlers = network["rattlers"].as_array().unwrap().len() as f64;
    assert_eq!(n, 343.0);
    assert!(phi > 0.60 && phi < 0.66, "jammed at {phi}");
    assert_eq!(network["overlaps"], 0);
    assert_eq!(network["isostatic_contact_number"], 6.0);
    assert!((z - 6.0).abs() < 0.5, "z = {z}");
    assert!(rattlers / n < 0.15, "{rattlers} rattlers");
    // The contact numbers and the contacts agree.
    let contacts = network["contacts"].as_array().unwrap().len() as f64;
    let total: f64 = network["contact_numbers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|z| z.as_f64().unwrap())
        .sum();
    assert_eq!(total, 2.0 * contacts);

    // A tolerance far below the compression's gaps: no backbone is held.
    let strict = analyze(&log, "1e-9");
    assert!(strict["contacts"].as_array().unwrap().len() < contacts as usize / 2);
    let _ = std::fs::remove_dir_all(&dir);
}
