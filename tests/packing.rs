//! `hardbody analyze LOG --packing`: a packing jammed by growth read at
//! the gap the packing itself shows is isostatic (a mean contact number
//! of the backbone within 0.1 of 2 d_f = 6) with a few per cent
//! rattlers, with no flag given; a packing jammed by compression, whose
//! contacts no gap separates from its near neighbours, gets a warning
//! instead of a certificate.

use std::path::Path;
use std::process::Command;

const JAMMED: &str = r#"Scene(
    seed: 5,
    box: (12.0, 12.0, 12.0),
    species: [Species(name: "ball", shape: Sphere(radius: 0.5), count: 343)],
    start: Lattice,
    stages: [Compress(packing_fraction: 0.74, until_jammed: true)],
    log: Log(path: "jammed.mcap", stats_every: 100, frames_every: 5000),
)"#;

/// Runs `command` to success; its standard output.
fn succeed(command: &mut Command) -> Vec<u8> {
    let out = command.output().unwrap();
    assert!(
        out.status.success(),
        "{command:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    out.stdout
}

/// `hardbody run SCENE --out LOG`.
fn run(scene: &Path, log: &Path) {
    succeed(
        Command::new(env!("CARGO_BIN_EXE_hardbody"))
            .arg("run")
            .arg(scene)
            .arg("--out")
            .arg(log),
    );
}

/// The JSON a Python `script` prints, given `input` as its argument.
fn python(script: &str, input: &Path) -> serde_json::Value {
    serde_json::from_slice(&succeed(
        Command::new("python3").args(["-c", script]).arg(input),
    ))
    .unwrap()
}

/// `analyze --packing --json`, at `gap` if given.
fn analyze(log: &Path, gap: Option<&str>) -> serde_json::Value {
    let mut command = Command::new(env!("CARGO_BIN_EXE_hardbody"));
    command.args(["analyze", "--packing", "--json"]);
    if let Some(gap) = gap {
        command.args(["--gap", gap]);
    }
    serde_json::from_slice(&succeed(command.arg(log))).unwrap()
}

fn scratch(name: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("hardbody-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// 250 spheres compressed to 0.45 and grown at the default rate until
/// βPV/N passes 10¹².
const GROWN: &str = r#"Scene(
    seed: 7,
    box: (10.0, 10.0, 10.0),
    species: [Species(name: "ball", shape: Sphere(radius: 0.5), count: 250)],
    stages: [Compress(packing_fraction: 0.45), Jam()],
    log: Log(path: "grown.mcap", stats_every: 100, frames_every: 5000),
)"#;

/// `hardbody run SCENE --out LOG`: (standard output, standard error).
fn run_saying(scene: &Path, log: &Path) -> (String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .arg("run")
        .arg(scene)
        .arg("--out")
        .arg(log)
        .output()
        .unwrap();
    assert!(out.status.success());
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_grown_sphere_packing_is_isostatic_at_the_gap_it_shows() {
    let dir = scratch("packing-grown");
    let scene = dir.join("grown.ron");
    std::fs::write(&scene, GROWN).unwrap();
    let log = dir.join("grown.mcap");
    // The jam stage certifies its packing as it ends.
    let (said, _) = run_saying(&scene, &log);
    assert!(
        said.contains("jammed at packing fraction") && said.contains("backbone of"),
        "{said}"
    );
    let report = analyze(&log, None);
    let gap = &report["gap"];
    assert_eq!(gap["source"], "plateau", "{gap}");
    assert!(gap["warning"].is_null());
    let z_frame = gap["reduced_pressure"].as_f64().unwrap();
    assert!(z_frame > 1e12, "betaPV/N {z_frame}");
    // The gap lies above the contacts (near 1/Z) and far below the near
    // neighbours, on a range where the count is flat.
    let g = gap["gap"].as_f64().unwrap();
    assert!(g > 100.0 / z_frame && g < 1e-4, "gap {g}");
    let flattest = &gap["flattest"];
    assert!(flattest["added"].as_f64().unwrap() <= 0.01 * flattest["contacts"].as_f64().unwrap());
    let network = &report["network"];
    let z = network["backbone_contact_number"].as_f64().unwrap();
    let rattlers = network["rattlers"].as_array().unwrap().len() as f64 / 250.0;
    assert!((z - 6.0).abs() < 0.1, "z = {z}");
    assert!(rattlers > 0.0 && rattlers < 0.08, "rattlers {rattlers}");
    assert_eq!(network["overlaps"], 0);
    // At the fixed gap of packings jammed by compression the same frame
    // counts near neighbours as contacts: hyperstatic, and wrong.
    let fixed = analyze(&log, Some("1e-2"));
    let z_fixed = fixed["network"]["backbone_contact_number"]
        .as_f64()
        .unwrap();
    assert!(z_fixed > 6.3, "z at 1e-2 = {z_fixed}");
    assert_eq!(fixed["gap"]["source"], "given");
    // The count against the gap, in the plots.
    let plots = dir.join("plots");
    succeed(
        Command::new(env!("CARGO_BIN_EXE_hardbody"))
            .args(["analyze", "--packing", "--plot"])
            .arg(&plots)
            .arg(&log),
    );
    let svg = std::fs::read_to_string(plots.join("contacts-against-gap.svg")).unwrap();
    assert!(svg.contains("<svg") && svg.contains("gap"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Grown ten times faster, the same spheres pass βPV/N = 10¹² on a
/// backbone with floppy modes (the pressure was made by the growth); the
/// stage rests them at their size and grows on at a tenth of the rate,
/// and the packing it hands over is isostatic within 0.1, with a few
/// percent of rattlers, read with no flag.
#[test]
fn a_jam_grown_faster_than_it_settles_settles_before_it_ends() {
    let dir = scratch("packing-fast");
    let scene = dir.join("fast.ron");
    std::fs::write(&scene, GROWN.replace("Jam()", "Jam(growth_rate: 1e-2)")).unwrap();
    let log = dir.join("fast.mcap");
    let (said, noted) = run_saying(&scene, &log);
    assert!(
        said.contains("jammed at packing fraction") && said.contains("settling round"),
        "{said}"
    );
    assert!(!noted.contains("NOT certified"), "{noted}");
    let report = analyze(&log, None);
    assert_eq!(report["gap"]["source"], "plateau");
    let network = &report["network"];
    let z = network["backbone_contact_number"].as_f64().unwrap();
    assert!((z - 6.0).abs() < 0.1, "backbone z = {z}");
    let rattlers = network["rattlers"].as_array().unwrap().len();
    assert!((1..=25).contains(&rattlers), "{rattlers} rattlers of 250");
    let _ = std::fs::remove_dir_all(&dir);
}

/// Without settling rounds, the fast growth ends on a packing whose
/// backbone lacks isostatic contacts, and the certificate says so.
#[test]
fn without_settling_a_fast_jam_is_not_certified() {
    use hardbody::edmd::DynamicsOptions;
    use hardbody::edmd::jam::{JamOptions, certificate, jam};
    use hardbody::space::PeriodicBox;
    use hardbody::state::{Species, start::lattice};
    use rand::SeedableRng;
    let shape = "Sphere(radius: 0.5)".parse().unwrap();
    let species = vec![Species {
        name: "ball".into(),
        shape,
        rotation: false,
    }];
    let edge = (250.0 * std::f64::consts::PI / 6.0 / 0.2_f64).cbrt();
    let box_ = PeriodicBox::new(nalgebra::Vector3::repeat(edge)).unwrap();
    let mut rng = rand_pcg::Pcg64::seed_from_u64(7);
    let start = lattice(box_, species, &[250], &mut rng).unwrap();
    let options = |settle_rounds| JamOptions {
        growth_rate: 1e-2,
        settle_rounds,
        ..JamOptions::default()
    };
    let fast = jam(
        &start,
        &options(0),
        &DynamicsOptions::default(),
        &mut rng,
        |_| true,
    )
    .unwrap();
    let z = fast.last.unwrap().pressure;
    assert!(z >= 1e12, "betaPV/N {z}");
    let reading = certificate(&fast.system, Some(z));
    assert!(
        !reading.jammed(),
        "{:?}",
        reading.network.backbone_contact_number
    );
    // Held, but hypostatic: floppy modes, not a jammed packing.
    let held = reading.held;
    let backbone = reading.network.backbone_contact_number;
    assert!(held == 0 || backbone < 5.9, "{held} held, z = {backbone}");
}

#[test]
fn a_packing_jammed_by_compression_gets_a_warning_not_a_certificate() {
    let dir = scratch("packing");
    let scene = dir.join("jammed.ron");
    std::fs::write(&scene, JAMMED).unwrap();
    let log = dir.join("jammed.mcap");
    run(&scene, &log);

    // No plateau: the fallback gap, and a warning in the JSON and on
    // standard error.
    let report = analyze(&log, None);
    assert_eq!(report["gap"]["source"], "no_plateau");
    assert!(
        report["gap"]["warning"]
            .as_str()
            .unwrap()
            .contains("no plateau")
    );
    let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args(["analyze", "--packing"])
        .arg(&log)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("warning: no plateau"));
    assert!(String::from_utf8_lossy(&out.stdout).contains("no plateau"));
    // Spheres have no cubatic order to report.
    assert!(report["cubatic"].is_null(), "{}", report["cubatic"]);
    let network = &report["network"];
    let n = network["bodies"].as_u64().unwrap() as f64;
    let phi = network["packing_fraction"].as_f64().unwrap();
    // null where no body is held.
    let z = network["backbone_contact_number"]
        .as_f64()
        .unwrap_or(f64::NAN);
    let rattlers = network["rattlers"].as_array().unwrap().len() as f64;
    assert_eq!(n, 343.0);
    assert!(phi > 0.60 && phi < 0.66, "jammed at {phi}");
    assert_eq!(network["overlaps"], 0);
    // Read at 1e-2, near neighbours pass for contacts, and the bodies
    // they hold on one side only come loose.
    assert!(z.is_nan() || (z - 6.0).abs() < 0.6, "z = {z}");
    assert!(rattlers / n > 0.0, "{rattlers} rattlers");
    // The contact numbers and the contacts agree.
    let contacts = network["contacts"].as_array().unwrap().len() as f64;
    let total: f64 = network["contact_numbers"]
        .as_array()
        .unwrap()
        .iter()
        .map(|z| z.as_f64().unwrap())
        .sum();
    assert_eq!(total, 2.0 * contacts);

    // S(k) from g(r): its first peak where dense spheres have it, near
    // 2π/σ (times about 1.1 to 1.2).
    let k = report["structure_factor"]["k"].as_array().unwrap();
    let s_k = report["structure_factor"]["s"].as_array().unwrap();
    let peak = (0..k.len())
        .max_by(|&a, &b| {
            s_k[a]
                .as_f64()
                .unwrap()
                .total_cmp(&s_k[b].as_f64().unwrap())
        })
        .unwrap();
    let k_peak = k[peak].as_f64().unwrap();
    assert!(k_peak > 6.5 && k_peak < 8.0, "S(k) peaks at k = {k_peak}");
    // The plots.
    let plots = dir.join("plots");
    succeed(
        Command::new(env!("CARGO_BIN_EXE_hardbody"))
            .args(["analyze", "--packing", "--plot"])
            .arg(&plots)
            .arg(&log),
    );
    for name in ["rdf.svg", "structure-factor.svg", "contact-numbers.svg"] {
        let svg = std::fs::read_to_string(plots.join(name)).unwrap();
        assert!(svg.contains("<svg") && svg.len() > 5000, "{name}");
    }

    // A tolerance far below the compression's gaps: no backbone is held.
    let strict = analyze(&log, Some("1e-9"));
    assert!(strict["network"]["contacts"].as_array().unwrap().len() < contacts as usize / 2);
    let _ = std::fs::remove_dir_all(&dir);
}

/// The structure `analyze --packing` reports agrees with freud's (where
/// the `freud-analysis` package is installed; `pip install
/// freud-analysis`): g(r) on the same bins, Steinhardt's Q4 and Q6 per
/// particle and locally averaged over the same neighbours, and the
/// nematic order of ellipsoids.
#[test]
fn structure_agrees_with_freud() {
    let has_freud = Command::new("python3")
        .args(["-c", "import freud"])
        .output()
        .is_ok_and(|o| o.status.success());
    if !has_freud {
        eprintln!(
            "skipped: the Python package freud is not installed (pip install freud-analysis)"
        );
        return;
    }
    let dir = std::env::temp_dir().join(format!("hardbody-freud-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("jammed.ron");
    std::fs::write(&scene, JAMMED.replace("0.74, until_jammed: true", "0.55")).unwrap();
    let log = dir.join("jammed.mcap");
    run(&scene, &log);
    let ours = analyze(&log, Some("1e-2"));

    let contents = hardbody::log::read::read_log(&log, false).unwrap();
    let (_, state) = contents.last_state.unwrap();
    let frame = dir.join("frame.json");
    std::fs::write(
        &frame,
        serde_json::json!({
            "box": state.box_lengths,
            "positions": state.positions,
            "bins": ours["rdf"]["r"].as_array().unwrap().len(),
            "r_max": 2.0 * ours["rdf"]["r"][0].as_f64().unwrap() * ours["rdf"]["r"].as_array().unwrap().len() as f64,
            "cutoff": ours["steinhardt_cutoff"],
        })
        .to_string(),
    )
    .unwrap();
    let script = r#"
import json, sys, numpy as np, freud
f = json.load(open(sys.argv[1]))
box = freud.box.Box(*f["box"])
points = np.array(f["positions"], dtype=float)
rdf = freud.density.RDF(bins=f["bins"], r_max=f["r_max"]).compute((box, points))
out = {"rdf": rdf.rdf.tolist()}
for l in (4, 6):
    for average in (False, True):
        st = freud.order.Steinhardt(l, average=average)
        st.compute((box, points), neighbors={"r_max": f["cutoff"]})
        out[f"q{l}{'avg' if average else ''}"] = float(np.nanmean(st.particle_order))
print(json.dumps(out))
"#;
    let theirs = python(script, &frame);

    // freud divides by the density N/V where hardbody takes the N − 1
    // partners each centre has, (N − 1)/V; and it measures distances in
    // single precision, which may put a pair near a bin's edge in the
    // next bin: two pairs' worth of difference is allowed.
    let n = state.positions.len() as f64;
    let g_ours: Vec<f64> = ours["rdf"]["g"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    let g_theirs: Vec<f64> = theirs["rdf"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect();
    assert_eq!(g_ours.len(), g_theirs.len());
    for (k, (a, b)) in g_ours.iter().zip(&g_theirs).enumerate() {
        let a = a * (n - 1.0) / n;
        let r = ours["rdf"]["r"][k].as_f64().unwrap();
        let width = 2.0 * ours["rdf"]["r"][0].as_f64().unwrap();
        let shell = 4.0 / 3.0
            * std::f64::consts::PI
            * ((r + width / 2.0).powi(3) - (r - width / 2.0).powi(3));
        let volume: f64 = state.box_lengths.iter().product();
        let one_pair = 2.0 / (n * n / volume * shell);
        assert!(
            (a - b).abs() <= 2.0 * one_pair + 1e-5 * (1.0 + b.abs()),
            "g(r) bin {k}: {a} vs freud {b} (one pair is {one_pair})"
        );
    }
    for (index, l) in [(0, 4), (1, 6)] {
        let q = &ours["steinhardt"][index];
        for (mine, key) in [
            ("mean", format!("q{l}")),
            ("mean_local_average", format!("q{l}avg")),
        ] {
            let (a, b) = (q[mine].as_f64().unwrap(), theirs[&key].as_f64().unwrap());
            assert!((a - b).abs() < 1e-5, "Q{l} {mine}: {a} vs freud {b}");
        }
    }
    // The nematic order of prolate ellipsoids (molecular axis: body x).
    let rods = dir.join("rods.ron");
    std::fs::write(
        &rods,
        r#"Scene(seed: 9, box: (14.0, 14.0, 14.0),
            species: [Species(name: "rod", shape: Ellipsoid(a: 1.5, b: 0.5, c: 0.5), count: 200)],
            start: Lattice,
            stages: [Compress(packing_fraction: 0.3), MonteCarlo(ensemble: Nvt, sweeps: 200)],
            log: Log(path: "rods.mcap", stats_every: 100, frames_every: 100))"#,
    )
    .unwrap();
    let rods_log = dir.join("rods.mcap");
    run(&rods, &rods_log);
    let ours = analyze(&rods_log, Some("1e-2"));
    let (_, state) = hardbody::log::read::read_log(&rods_log, false)
        .unwrap()
        .last_state
        .unwrap();
    let frame = dir.join("rods.json");
    std::fs::write(
        &frame,
        serde_json::json!({"q": state.orientations}).to_string(),
    )
    .unwrap();
    let script = r#"
import json, sys, numpy as np, freud
q = np.array(json.load(open(sys.argv[1]))["q"])
w, x, y, z = q.T
# The body x axis turned by each quaternion [w, x, y, z].
axes = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y + w * z), 2 * (x * z - w * y)], axis=1)
nematic = freud.order.Nematic().compute(axes)
print(json.dumps({"order": float(nematic.order), "director": [float(v) for v in nematic.director]}))
"#;
    let theirs = python(script, &frame);
    let (a, b) = (
        ours["nematic"]["order"].as_f64().unwrap(),
        theirs["order"].as_f64().unwrap(),
    );
    assert!((a - b).abs() < 1e-5, "S2 {a} vs freud {b}");
    let director = |v: &serde_json::Value| -> Vec<f64> {
        v.as_array()
            .unwrap()
            .iter()
            .map(|x| x.as_f64().unwrap())
            .collect()
    };
    let (d, e) = (
        director(&ours["nematic"]["director"]),
        director(&theirs["director"]),
    );
    let cosine: f64 = d.iter().zip(&e).map(|(x, y)| x * y).sum();
    assert!(cosine.abs() > 0.999, "directors {d:?} and {e:?}");
    let _ = std::fs::remove_dir_all(&dir);
}
