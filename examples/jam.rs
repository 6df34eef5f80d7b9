//! A jammed packing of any shape with the library: event-driven growth
//! from a dilute lattice, the contact network of the result, the time.
//!
//! `cargo run --release --example jam -- "Ellipsoid(a: 0.75, b: 0.5, c: 0.5)" 1000 1e-3`
//! (shape in the scene spelling, the number of bodies, the growth rate,
//! and optionally the bound on βPV/N; defaults: 1000 spheres at 10⁻³ to
//! 10¹², about 40 s on one core).
//!
//! A chunk that fails numerically is run again at half the rate; its
//! dynamics where it failed is written to `jam-failure-<chunk>.json`, and
//! `cargo run --release --example jam -- --replay jam-failure-<chunk>.json`
//! predicts the failing event again from it (seconds, not the run up to
//! it): the way to look at a failure's pose.

use std::time::Instant;

use hardbody::edmd::jam::{JamFailure, JamOptions, JamRun, jam_predictor};
use hardbody::edmd::{DynamicsDump, DynamicsOptions, PredictorOptions};
use hardbody::geometry::Shape;
use hardbody::space::PeriodicBox;
use hardbody::state::Species;
use hardbody::state::start::lattice;
use nalgebra::Vector3;
use rand::SeedableRng;
use rand_pcg::Pcg64;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if let [flag, path] = &args[..]
        && flag == "--replay"
    {
        return replay(path);
    }
    let shape: Shape = args
        .first()
        .map_or("Sphere(radius: 0.5)", String::as_str)
        .parse()
        .unwrap_or_else(|e| panic!("the shape: {e}"));
    let n: usize = args
        .get(1)
        .map_or(Ok(1000), |s| s.parse())
        .expect("a count");
    let rate: f64 = args.get(2).map_or(Ok(1e-3), |s| s.parse()).expect("a rate");
    let pressure: f64 = args
        .get(3)
        .map_or(Ok(1e12), |s| s.parse())
        .expect("a pressure");
    let species = vec![species_of(shape)];
    // A lattice at packing fraction 0.2, random orientations where the
    // sites are far enough apart.
    let edge = (n as f64 * shape.volume() / 0.2).cbrt();
    let box_ = PeriodicBox::new(Vector3::repeat(edge)).expect("a valid box");
    let mut rng = Pcg64::seed_from_u64(3);
    let start = lattice(box_, species, &[n], &mut rng).expect("room on the lattice");
    let options = JamOptions {
        growth_rate: rate,
        pressure,
        ..JamOptions::default()
    };
    let clock = Instant::now();
    let mut run =
        JamRun::new(&start, &options, &DynamicsOptions::default(), &mut rng).expect("a jam");
    let mut retries = 0;
    while let Some(c) = run.chunk().expect("a jam") {
        // A chunk that failed numerically ran again at half the rate.
        if run.progress().retries > retries {
            retries = run.progress().retries;
            eprintln!(
                "chunk {}: run again at rate {:e} after: {}",
                c.chunk,
                c.growth_rate,
                run.last_failure().unwrap_or("?")
            );
            if let Some(failure) = run.last_failure_replay() {
                let path = format!("jam-failure-{}.json", c.chunk);
                match std::fs::write(&path, failure_json(failure)) {
                    Ok(()) => eprintln!("  its dynamics: {path} (--replay {path})"),
                    Err(e) => eprintln!("  could not write {path}: {e}"),
                }
            }
        }
        if c.chunk % 10 == 0 {
            eprintln!(
                "chunk {}: phi {:.4}, betaPV/N {:.3e}, {} collisions, rate {:e}",
                c.chunk, c.packing_fraction, c.pressure, c.collisions, c.growth_rate
            );
        }
    }
    let end = run.end().expect("ended");
    if let Some(failure) = run.last_failure() {
        eprintln!("the last failure: {failure}");
    }
    let seconds = clock.elapsed().as_secs_f64();
    let system = run.system();
    let net = system.contact_network(1e-9);
    let last = run.progress().last.expect("a chunk");
    println!(
        "{shape}, N = {n}, growth rate {rate:e}: {:?} at phi = {:.4}, betaPV/N = {:.3e}, \
         z = {:.3}, constraints {:.3} (isostatic {}), {:.1} % rattlers, all bodies z = {:.3}, constraints {:.3}, {} overlaps, {} collisions, {seconds:.1} s",
        end,
        system.packing_fraction(),
        last.pressure,
        net.backbone_contact_number,
        net.backbone_constraint_number,
        net.isostatic_contact_number,
        100.0 * net.rattlers.len() as f64 / n as f64,
        net.mean_contact_number,
        net.mean_constraint_number,
        net.overlaps,
        last.collisions
    );
}

/// The one species of this example's runs.
fn species_of(shape: Shape) -> Species {
    Species {
        name: shape.kind().into(),
        shape,
        rotation: !shape.is_sphere(),
    }
}

/// A failed chunk as JSON: the message, the dump, the chunk's shapes (scene
/// spelling) and neighbour shell. Its other options are the defaults this
/// example runs with, tightened as a jam tightens them.
fn failure_json(failure: &JamFailure) -> String {
    serde_json::json!({
        "message": failure.message,
        "shapes": failure.species.iter().map(|s| s.shape.to_string()).collect::<Vec<_>>(),
        "neighbour_shell": failure.options.neighbour_shell,
        "dump": failure.dump,
    })
    .to_string()
}

/// Rebuilds a failed chunk from its JSON and runs it on to the end of its
/// growth: the failing event comes again.
fn replay(path: &str) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    let json: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    let species: Vec<Species> = json["shapes"]
        .as_array()
        .expect("shapes")
        .iter()
        .map(|s| species_of(s.as_str().expect("a shape").parse().expect("a shape")))
        .collect();
    let options = DynamicsOptions {
        neighbour_shell: json["neighbour_shell"].as_f64(),
        predictor: jam_predictor(PredictorOptions::default()),
        ..DynamicsOptions::default()
    };
    let dump: DynamicsDump = serde_json::from_value(json["dump"].clone()).expect("a dump");
    let failure = JamFailure {
        message: json["message"].as_str().unwrap_or_default().into(),
        dump,
        species,
        options,
    };
    let mut md = failure.replay().expect("the chunk rebuilt");
    let ends = md.growth_ends().expect("growing");
    eprintln!("{path}: failed with: {}", failure.message);
    match md.run_collisions_until(u64::MAX, ends) {
        Err(e) => println!("replayed: {e}"),
        Ok(()) => println!(
            "replayed to the end of the growth without that failure ({} collisions)",
            md.collisions()
        ),
    }
}
