//! Free energies of crystals against published values and against an
//! independent route.

use std::sync::atomic::AtomicBool;

use hardbody::free_energy::{
    CoexistenceOptions, EquationOfState, FreeEnergy, FreeEnergyError, FrenkelLadd, Phase,
    PhaseScene, branch_below, crystal_free_energy, fluid_free_energy, lattice_translations,
    scene_coexistence, solid_free_energy,
};
use hardbody::mc::einstein::Anchors;
use hardbody::run::Silent;
use hardbody::scene::Scene;
use hardbody::state::Species;
use hardbody::state::crystal::{CrystalSpec, UnitCell, crystal};

/// Hard spheres (σ = 1) on fcc at number density `density`, `cells`³
/// conventional cells.
fn fcc_spheres(density: f64, cells: usize) -> hardbody::state::System {
    let species = vec![Species {
        name: "sphere".into(),
        shape: "Sphere(radius: 0.5)".parse().unwrap(),
        rotation: false,
    }];
    let spec = CrystalSpec {
        cell: UnitCell::fcc(),
        cells: [cells; 3],
        packing_fraction: density * std::f64::consts::PI / 6.0,
    };
    crystal(&spec, species, &[4 * cells.pow(3)]).unwrap()
}

/// βF/N of the fcc hard-sphere crystal at `cells`³ conventional cells,
/// ρσ³ = 1.0409, with the default path.
fn fcc_free_energy(cells: usize) -> hardbody::free_energy::CrystalFreeEnergy {
    let system = fcc_spheres(1.0409, cells);
    let anchors = Anchors::of(&system);
    let translations = lattice_translations(&system);
    assert_eq!(translations, system.len());
    let options = FrenkelLadd {
        seed: cells as u64,
        ..FrenkelLadd::default()
    };
    crystal_free_energy(
        &system,
        &anchors,
        translations,
        &options,
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap()
}

/// The defect-free fcc hard-sphere crystal at ρσ³ = 1.0409: βF/N less
/// the ideal gas's ln ρ − 1, at N = 108, 256 and 500, each to better than
/// 0.003, and extrapolated linearly in 1/N, is Polson, Trizac, Pronk &
/// Frenkel's 5.91889(4) (J. Chem. Phys. 112, 5339 (2000), abstract)
/// within 0.005; the line fits the sizes (χ² under 3 per
/// degree of freedom).
#[test]
fn hard_sphere_fcc_free_energy_is_polsons() {
    let sizes = [3, 4, 5];
    let values: Vec<(usize, f64, f64)> = sizes
        .iter()
        .map(|&cells| {
            let r = fcc_free_energy(cells);
            println!(
                "N {:4}: βF/N {:.5} ± {:.5}, excess {:.5}, λ_max {:.0}, P₀ {:.4}",
                r.n,
                r.free_energy_per_particle,
                r.error,
                r.excess_free_energy_per_particle,
                r.spring_max,
                r.overlap_free
            );
            assert!(r.error < 0.003, "N {}: error {}", r.n, r.error);
            // A point whose two halves disagree by chance (3σ) happens;
            // more than two of twelve would be drift.
            let unsettled = r.path.iter().filter(|p| !p.spread.equilibrated).count();
            assert!(unsettled <= 2, "N {}: {unsettled} points drift", r.n);
            (r.n, r.excess_free_energy_per_particle, r.error)
        })
        .collect();
    let fit = hardbody::free_energy::extrapolate_in_size(&values).unwrap();
    println!(
        "N → ∞: {:.5} ± {:.5} (slope {:.2}, χ² {:.2})",
        fit.value, fit.error, fit.slope, fit.chi_squared
    );
    assert!((fit.value - 5.91889).abs() < 0.005, "{fit:?}");
    assert!(
        fit.chi_squared < 3.0 * (sizes.len() - 2) as f64 + 1.0,
        "{fit:?}"
    );
}

/// `solid_free_energy` of a scene given as text, its log in a fresh
/// folder; the log's path is returned with the result.
fn solid_of_scene(
    text: &str,
    options: &FrenkelLadd,
    name: &str,
) -> (
    Result<hardbody::free_energy::CrystalFreeEnergy, FreeEnergyError>,
    std::path::PathBuf,
) {
    let dir = std::env::temp_dir().join(format!("hardbody-fe-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("run.mcap");
    let scene = Scene::parse(text).unwrap();
    let result = solid_free_energy(
        &scene,
        text,
        &log,
        options,
        &mut Silent,
        &AtomicBool::new(false),
    );
    (result, log)
}

/// `scene_free_energy` (crystal or fluid, as the start says) of a scene
/// given as text, its log in a fresh folder.
fn scene_free_energy(
    text: &str,
    options: &FrenkelLadd,
    name: &str,
) -> (Result<FreeEnergy, FreeEnergyError>, std::path::PathBuf) {
    let dir = std::env::temp_dir().join(format!("hardbody-fe-{name}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("run.mcap");
    let scene = Scene::parse(text).unwrap();
    let result = hardbody::free_energy::scene_free_energy(
        &scene,
        text,
        &log,
        options,
        &EquationOfState::default(),
        &mut Silent,
        &AtomicBool::new(false),
    );
    (result, log)
}

/// 108 spheres of diameter 1 from `start`, a short NVT stage.
fn spheres_scene(start: &str) -> String {
    let box_ = if start.starts_with("Crystal") {
        ""
    } else {
        "box: (8.0, 8.0, 8.0),"
    };
    format!(
        r#"Scene(species: [Species(name: "s", shape: Sphere(radius: 0.5), count: 108)],
            start: {start}, {box_}
            stages: [MonteCarlo(ensemble: Nvt, sweeps: 200)],
            log: Log(path: "x.mcap", stats_every: 100, frames_every: 100))"#
    )
}

/// What cannot give a crystal's free energy is refused with a message
/// naming why, and nothing is printed as a result: a fluid scene (no
/// lattice; refused before it runs, so no log is written), springs too
/// weak for the
/// Einstein crystal to be overlap-free, springs far stronger than the
/// path resolves, and a crystal that melts on the path.
#[test]
fn what_has_no_crystal_free_energy_is_refused() {
    let quick = FrenkelLadd {
        sweeps: 400,
        equilibration: 200,
        points: 4,
        einstein_samples: 500,
        ..FrenkelLadd::default()
    };
    let (fluid, log) = solid_of_scene(&spheres_scene("Random"), &quick, "fluid");
    let e = fluid.unwrap_err();
    assert!(matches!(e, FreeEnergyError::NoLattice(_)), "{e}");
    assert!(e.to_string().contains("needs a lattice"), "{e}");
    assert!(!log.exists());

    let crystal = spheres_scene("Crystal(lattice: Fcc, cells: (3, 3, 3), packing_fraction: 0.545)");
    let weak = FrenkelLadd {
        spring: Some(5.0),
        ..quick.clone()
    };
    let e = solid_of_scene(&crystal, &weak, "weak").0.unwrap_err();
    assert!(matches!(e, FreeEnergyError::SpringsTooWeak { .. }), "{e}");
    assert!(e.to_string().contains("too weak"), "{e}");
    let strong = FrenkelLadd {
        spring: Some(1e9),
        ..quick.clone()
    };
    let e = solid_of_scene(&crystal, &strong, "strong").0.unwrap_err();
    assert!(matches!(e, FreeEnergyError::PathOutOfRange { .. }), "{e}");

    // fcc at φ = 0.25 is far below melting: its bodies leave their sites
    // in the free crystal's run, and a state that has already left them
    // (after a longer stage) cannot be tethered.
    let dilute = spheres_scene("Crystal(lattice: Fcc, cells: (3, 3, 3), packing_fraction: 0.25)");
    let e = solid_of_scene(&dilute.replace("sweeps: 200", "sweeps: 1"), &quick, "melts")
        .0
        .unwrap_err();
    assert!(
        matches!(e, FreeEnergyError::Melted { spring: 0.0, .. }),
        "{e}"
    );
    assert!(e.to_string().contains("melted"), "{e}");
    let e = solid_of_scene(
        &dilute.replace("sweeps: 200", "sweeps: 3000"),
        &quick,
        "melted",
    )
    .0
    .unwrap_err();
    assert!(matches!(e, FreeEnergyError::Tether(_)), "{e}");
    assert!(e.to_string().contains("from its site"), "{e}");
}

/// The command: JSON with the fields the docs name and the path's points,
/// the plot written; springs for a fluid scene refused with exit code 2,
/// its log never started.
#[test]
fn the_free_energy_command_prints_json_and_refuses_springs_for_fluids() {
    let dir = std::env::temp_dir().join(format!("hardbody-fe-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    let hardbody = env!("CARGO_BIN_EXE_hardbody");
    let out = std::process::Command::new(hardbody)
        .arg("free-energy")
        .arg(root.join("data/scenes/hard_sphere_fcc_free_energy.ron"))
        .args(["--json", "--points", "4", "--sweeps", "400", "--out"])
        .arg(dir.join("fcc.mcap"))
        .arg("--plot")
        .arg(dir.join("plots"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["n"], 256);
    assert_eq!(json["path"].as_array().unwrap().len(), 4);
    let f = json["free_energy_per_particle"].as_f64().unwrap();
    let error = json["error"].as_f64().unwrap();
    assert!(error > 0.0 && (f - 4.93).abs() < 0.1, "{f} ± {error}");
    assert!((json["packing_fraction"].as_f64().unwrap() - 0.545019).abs() < 1e-5);
    assert!(dir.join("fcc.mcap").exists());
    assert!(dir.join("plots/frenkel_ladd_path.svg").exists());

    let fluid = std::process::Command::new(hardbody)
        .arg("free-energy")
        .arg(root.join("data/scenes/default.ron"))
        .args(["--spring", "1000", "--out"])
        .arg(dir.join("fluid.mcap"))
        .output()
        .unwrap();
    assert_eq!(fluid.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&fluid.stderr).contains("springs tether a crystal"));
    assert!(fluid.stdout.is_empty());
    assert!(!dir.join("fluid.mcap").exists());
}

/// Carnahan–Starling–Kolafa's excess free energy of the hard-sphere
/// fluid, βF_ex/N = (5/3) ln(1 − η) + η(34 − 33η + 4η²)/(6(1 − η)²),
/// the integral of its Z = (1 + η + η² − (2/3)(η³ + η⁴))/(1 − η)³
/// (Boublík & Nezbeda, Collect. Czech. Chem. Commun. 51, 2301 (1986)).
fn kolafa_excess(eta: f64) -> f64 {
    5.0 / 3.0 * (1.0 - eta).ln()
        + eta * (34.0 - 33.0 * eta + 4.0 * eta * eta) / (6.0 * (1.0 - eta).powi(2))
}

/// The hard-sphere fluid at φ = 0.40, 256 spheres: βF/N from its own
/// equation of state, integrated from the ideal gas, is Kolafa's within
/// three errors (the error under 0.02), as are βP and βμ at the state;
/// an fcc crystal given as a fluid is refused, naming its order.
#[test]
fn hard_sphere_fluid_free_energy_is_kolafas() {
    let (n, phi) = (256usize, 0.40);
    let side = (n as f64 * std::f64::consts::PI / 6.0 / 0.2).cbrt();
    let text = format!(
        r#"Scene(species: [Species(name: "s", shape: Sphere(radius: 0.5), count: {n})],
            start: Random, box: ({side}, {side}, {side}), seed: 3,
            stages: [Compress(packing_fraction: {phi}), MonteCarlo(ensemble: Nvt, sweeps: 2000)],
            log: Log(path: "x.mcap", stats_every: 100, frames_every: 1000))"#
    );
    let (result, _) = scene_free_energy(&text, &FrenkelLadd::default(), "fluid-eos");
    let FreeEnergy::EquationOfState(r) = result.unwrap() else {
        panic!("a fluid scene runs as a fluid")
    };
    let eta = r.packing_fraction;
    let excess = kolafa_excess(eta);
    let z = (1.0 + eta + eta * eta - 2.0 / 3.0 * (eta.powi(3) + eta.powi(4))) / (1.0 - eta).powi(3);
    let rho = r.number_density;
    let mu = rho.ln() - 1.0 + excess + z;
    println!(
        "excess {:.5} ± {:.5} (Kolafa {excess:.5}); βP {:.4} ± {:.4} ({:.4}); βμ {:.4} ± {:.4} ({mu:.4})",
        r.excess_free_energy_per_particle,
        r.error,
        r.pressure.0,
        r.pressure.1,
        z * rho,
        r.chemical_potential.0,
        r.chemical_potential.1
    );
    assert!(r.error < 0.02, "{}", r.error);
    assert!((r.excess_free_energy_per_particle - excess).abs() < 3.0 * r.error);
    assert!((r.pressure.0 - z * rho).abs() < 3.0 * r.pressure.1);
    assert!((r.chemical_potential.0 - mu).abs() < 3.0 * r.chemical_potential.1);
    assert_eq!(r.path.len(), EquationOfState::default().points);

    let crystal = fcc_spheres(1.0409, 3);
    let e = fluid_free_energy(
        &crystal,
        &EquationOfState::default(),
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap_err();
    assert!(matches!(e, FreeEnergyError::Ordered { .. }), "{e}");
    assert!(e.to_string().contains("Q₆"), "{e}");
}

/// Hard-sphere fluid and fcc crystal scenes of `n` spheres: the fluid
/// compressed to `fluid_phi`, the crystal built at `solid_phi`.
fn hard_sphere_phases(
    n_fluid: usize,
    fluid_phi: f64,
    cells: usize,
    solid_phi: f64,
) -> (String, String) {
    let side = (n_fluid as f64 * std::f64::consts::PI / 6.0 / 0.2).cbrt();
    let fluid = format!(
        r#"Scene(species: [Species(name: "s", shape: Sphere(radius: 0.5), count: {n_fluid})],
            start: Random, box: ({side}, {side}, {side}), seed: 11,
            stages: [Compress(packing_fraction: {fluid_phi}), MonteCarlo(ensemble: Nvt, sweeps: 4000)],
            log: Log(path: "fluid.mcap", stats_every: 100, frames_every: 1000))"#
    );
    let solid = format!(
        r#"Scene(species: [Species(name: "s", shape: Sphere(radius: 0.5), count: {})],
            start: Crystal(lattice: Fcc, cells: ({cells}, {cells}, {cells}), packing_fraction: {solid_phi}), seed: 12,
            stages: [MonteCarlo(ensemble: Nvt, sweeps: 2000)],
            log: Log(path: "solid.mcap", stats_every: 100, frames_every: 1000))"#,
        4 * cells * cells * cells
    );
    (fluid, solid)
}

/// The independent check of the crystal branch: βF/N of the fcc
/// hard-sphere crystal by Frenkel–Ladd at φ = 0.56 and at 6 % lower
/// density differ by what its equation of state carries between them,
/// ∫ βP/ρ² dρ over the branch's fitted pressures, within three combined
/// errors (108 spheres: an identity at any N).
#[test]
fn the_crystal_branch_carries_frenkel_ladds_free_energy() {
    let high = 0.56 * 6.0 / std::f64::consts::PI;
    let low = high * 0.94;
    let free_energy = |density: f64| {
        let system = fcc_spheres(density, 3);
        let r = crystal_free_energy(
            &system,
            &Anchors::of(&system),
            system.len(),
            &FrenkelLadd::default(),
            &mut Silent,
            &AtomicBool::new(false),
        )
        .unwrap();
        (system, r)
    };
    let (dense, at_high) = free_energy(high);
    let (_, at_low) = free_energy(low);
    let options = CoexistenceOptions {
        span: 0.06,
        ..CoexistenceOptions::default()
    };
    let branch = branch_below(
        &dense,
        (at_high.free_energy_per_particle, at_high.error),
        Phase::Crystal,
        &options,
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap();
    let carried = branch.free_energy_at(low);
    let error =
        (at_high.error.powi(2) + at_low.error.powi(2) + branch.carried_error(low).powi(2)).sqrt();
    println!(
        "βF/N at ρ {low:.5}: Frenkel–Ladd {:.5} ± {:.5}, carried from ρ {high:.5} {carried:.5} (± {error:.5} combined); χ² of the fit {:.2}",
        at_low.free_energy_per_particle, at_low.error, branch.chi_squared
    );
    assert!(error < 0.01, "{error}");
    assert!((carried - at_low.free_energy_per_particle).abs() < 3.0 * error);
    // The check can fail: the difference it confirms is far larger than
    // its error.
    assert!(
        (at_high.free_energy_per_particle - at_low.free_energy_per_particle).abs() > 50.0 * error
    );
}

/// Hard-sphere freezing from the shipped scenes (1000 fluid spheres at
/// φ = 0.495, 2048 on fcc at 0.56) with the defaults, as `hardbody
/// coexistence` runs it (about 4 minutes on 2 cores): βP within three
/// errors of Fernández, Martín-Mayor, Seoane & Verrocchio's 11.5727(10)
/// (Phys. Rev. Lett. 108, 165701 (2012), abstract), the error under 0.2;
/// the densities within three errors of those the published equations of
/// state give at that pressure: 0.4919 for the fluid (Kolafa's,
/// Boublík & Nezbeda 1986) and 0.5434 for fcc (Speedy, J. Phys.:
/// Condens. Matter 10, 4387 (1998)).
#[test]
#[ignore]
fn hard_sphere_coexistence_is_fernandezs() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/scenes");
    let fluid = std::fs::read_to_string(root.join("hard_sphere_fluid.ron")).unwrap();
    let solid = std::fs::read_to_string(root.join("hard_sphere_fcc_coexistence.ron")).unwrap();
    let dir = std::env::temp_dir().join(format!("hardbody-coex-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (fs, ss) = (Scene::parse(&fluid).unwrap(), Scene::parse(&solid).unwrap());
    let t = std::time::Instant::now();
    let c = scene_coexistence(
        PhaseScene {
            scene: &fs,
            text: &fluid,
            log: &dir.join("fluid.mcap"),
        },
        PhaseScene {
            scene: &ss,
            text: &solid,
            log: &dir.join("solid.mcap"),
        },
        (
            &EquationOfState::default(),
            &FrenkelLadd::default(),
            &CoexistenceOptions::default(),
        ),
        &mut Silent,
        &AtomicBool::new(false),
    )
    .unwrap();
    println!(
        "{:.0} s: βP {:.4} ± {:.4}, φ_fluid {:.4} ± {:.4}, φ_crystal {:.4} ± {:.4}, βμ {:.4} ± {:.4}",
        t.elapsed().as_secs_f64(),
        c.pressure,
        c.pressure_error,
        c.fluid_packing_fraction,
        c.fluid_packing_fraction_error,
        c.solid_packing_fraction,
        c.solid_packing_fraction_error,
        c.chemical_potential.0,
        c.chemical_potential.1
    );
    assert!(c.pressure_error < 0.2, "{}", c.pressure_error);
    assert!((c.pressure - 11.5727).abs() < 3.0 * c.pressure_error);
    assert!((c.fluid_packing_fraction - 0.4919).abs() < 3.0 * c.fluid_packing_fraction_error);
    assert!((c.solid_packing_fraction - 0.5434).abs() < 3.0 * c.solid_packing_fraction_error);
}

/// `coexistence` on the command line: JSON with the fields the docs
/// name; the same study written as a workspace, its parts run one by one
/// as row would and collected, gives that JSON to the bit, and names a
/// part not done; a fluid scene given as the solid refused with exit
/// code 2 before anything runs.
#[test]
fn the_coexistence_command_prints_json_and_refuses_a_fluid_solid() {
    let dir = std::env::temp_dir().join(format!("hardbody-coex-cli-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let (fluid, solid) = hard_sphere_phases(256, 0.495, 4, 0.56);
    std::fs::write(dir.join("fluid.ron"), &fluid).unwrap();
    std::fs::write(dir.join("solid.ron"), &solid).unwrap();
    let hardbody = env!("CARGO_BIN_EXE_hardbody");
    let out = std::process::Command::new(hardbody)
        .current_dir(&dir)
        .args([
            "coexistence",
            "--fluid",
            "fluid.ron",
            "--solid",
            "solid.ron",
        ])
        .args(["--json", "--sweeps", "2000", "--plot", "plots"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    for key in [
        "pressure",
        "pressure_error",
        "fluid_packing_fraction",
        "fluid_packing_fraction_error",
        "solid_packing_fraction",
        "solid_packing_fraction_error",
    ] {
        assert!(json[key].as_f64().unwrap().is_finite(), "{key}");
    }
    let p = json["pressure"].as_f64().unwrap();
    assert!((9.0..14.0).contains(&p), "{p}");
    assert!(dir.join("plots/chemical_potentials.svg").exists());

    let run = |args: &[&str]| {
        let out = std::process::Command::new(hardbody)
            .current_dir(&dir)
            .args(args)
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr).to_string();
        (out.status.code(), out.stdout, stderr)
    };
    let (code, _, stderr) = run(&[
        "coexistence",
        "--fluid",
        "fluid.ron",
        "--solid",
        "solid.ron",
        "--sweeps",
        "2000",
        "--workspace",
        "study",
    ]);
    assert_eq!(code, Some(0), "{stderr}");
    let mut jobs: Vec<_> = std::fs::read_dir(dir.join("study/workspace"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    jobs.sort();
    // Both anchors and five points of each branch.
    assert_eq!(jobs.len(), 12);
    let (last, done) = jobs.split_last().unwrap();
    for job in done {
        let (code, _, stderr) = run(&["coexistence", "--job", job.to_str().unwrap()]);
        assert_eq!(code, Some(0), "{stderr}");
    }
    let (code, _, stderr) = run(&["coexistence", "--collect", "study", "--json"]);
    assert_eq!(code, Some(2));
    let id = last.file_name().unwrap().to_str().unwrap();
    assert!(
        stderr.contains("1 of the study's 12 parts are not done"),
        "{stderr}"
    );
    assert!(stderr.contains(id), "{stderr}");
    let (code, _, stderr) = run(&["coexistence", "--job", last.to_str().unwrap()]);
    assert_eq!(code, Some(0), "{stderr}");
    let (code, collected, stderr) = run(&["coexistence", "--collect", "study", "--json"]);
    assert_eq!(code, Some(0), "{stderr}");
    assert_eq!(
        String::from_utf8_lossy(&collected),
        String::from_utf8_lossy(&out.stdout)
    );

    let swapped = std::process::Command::new(hardbody)
        .current_dir(&dir)
        .args([
            "coexistence",
            "--fluid",
            "solid.ron",
            "--solid",
            "fluid.ron",
        ])
        .output()
        .unwrap();
    assert_eq!(swapped.status.code(), Some(2));
    let message = String::from_utf8_lossy(&swapped.stderr);
    assert!(message.contains("no lattice to tether"), "{message}");
}

/// Bodies that turn, on orientational springs that respect their
/// symmetry (a superball's 24 images, a spheroid's axis either way up):
/// βF/N of the crystal does not depend on how strong the orientational
/// springs are against the positional ones (κ and 10κ agree within three
/// errors), though the Einstein crystal's orientational term moves by
/// over twenty errors between the two: the quadrature of q(λ_o), the
/// direct samples and the Metropolis rotations agree on one free energy.
#[test]
fn crystal_free_energy_does_not_depend_on_the_orientational_springs() {
    for (shape, phi, cells, sweeps) in [
        (
            "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
            0.7,
            4,
            3_000,
        ),
        ("Ellipsoid(a: 0.5, b: 0.5, c: 0.75)", 0.65, 3, 5_000),
    ] {
        let species = vec![Species {
            name: "body".into(),
            shape: shape.parse().unwrap(),
            rotation: true,
        }];
        let spec = CrystalSpec {
            cell: UnitCell::densest(&species[0].shape).unwrap(),
            cells: [cells; 3],
            packing_fraction: phi,
        };
        let count = spec.cell.basis.len() * cells.pow(3);
        let system = crystal(&spec, species, &[count]).unwrap();
        let anchors = Anchors::of(&system);
        let run = |twist: Option<f64>| {
            let options = FrenkelLadd {
                sweeps,
                equilibration: sweeps / 10,
                twist,
                ..FrenkelLadd::default()
            };
            let translations = lattice_translations(&system);
            crystal_free_energy(
                &system,
                &anchors,
                translations,
                &options,
                &mut Silent,
                &AtomicBool::new(false),
            )
            .unwrap()
        };
        let chosen = run(None);
        let stiffer = run(Some(10.0 * chosen.twist));
        let error = chosen.error.hypot(stiffer.error);
        println!(
            "{shape}: βF/N {:.4} ± {:.4} (κ {:.4}), {:.4} ± {:.4} (10κ); orientational Einstein terms {:.4}, {:.4}",
            chosen.free_energy_per_particle,
            chosen.error,
            chosen.twist,
            stiffer.free_energy_per_particle,
            stiffer.error,
            chosen.einstein_orientations,
            stiffer.einstein_orientations
        );
        assert!(
            (chosen.free_energy_per_particle - stiffer.free_energy_per_particle).abs()
                < 3.0 * error
        );
        assert!(
            (chosen.einstein_orientations - stiffer.einstein_orientations).abs() > 20.0 * error
        );
    }
}
