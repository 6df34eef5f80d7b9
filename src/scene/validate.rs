//! The checks a scene passes before anything runs: every value in range,
//! every target reachable, every stage possible with the species and
//! walls given; each refusal names its field.

use crate::mc::box_moves::BoxMoves;

use super::*;
use crate::number::Num;
use crate::space::PeriodicBox;

impl Scene {
    /// Checks every field; on failure the field path and what is wrong.
    /// Whether `sweeps` sweeps of Monte Carlo stage `i` write at most
    /// [`MAX_STATS_PER_STAGE`] `/stats` messages and
    /// [`MAX_FRAMES_PER_STAGE`] frames.
    pub(super) fn check_messages(&self, i: usize, sweeps: u64) -> Result<(), (String, String)> {
        for (name, every, most) in [
            ("log.stats_every", self.log.stats_every, MAX_STATS_PER_STAGE),
            (
                "log.frames_every",
                self.log.frames_every,
                MAX_FRAMES_PER_STAGE,
            ),
        ] {
            let messages = sweeps as f64 / every.max(1) as f64;
            if messages > most {
                return Err((
                    name.to_string(),
                    format!(
                        "every {every} sweeps would write {messages:.3e} messages in the {sweeps} sweeps of stages[{i}]: at most {most:e} per stage"
                    ),
                ));
            }
        }
        Ok(())
    }

    /// Checks every part of the scene; on failure each part's first
    /// problem (field path, what is wrong), in the order of the scene. The
    /// start is checked only with a valid box and species, the stages only
    /// with a valid start as well (they need its packing fraction).
    pub(super) fn validate(&self) -> Result<(), Vec<(String, String)>> {
        let mut problems = Vec::new();
        let mut holds = |part: Result<(), (String, String)>| match part {
            Ok(()) => true,
            Err(problem) => {
                problems.push(problem);
                false
            }
        };
        let frame = holds(self.validate_box()) & holds(self.validate_species());
        if frame {
            let start = self.validate_start();
            if let Ok(box_) = &start {
                holds(self.validate_stages(box_));
            }
            holds(start.map(|_| ()));
        }
        holds(self.validate_log());
        holds(self.validate_accuracy());
        if problems.is_empty() {
            Ok(())
        } else {
            Err(problems)
        }
    }

    /// The box and the walls.
    fn validate_box(&self) -> Result<(), (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        let crystal = matches!(self.start, Start::Crystal { .. });
        match (crystal, self.box_spec) {
            (true, Some(_)) => {
                return bad(
                    "box",
                    "a Crystal start makes the box (its supercell): leave `box` out".into(),
                );
            }
            (true, None) => {
                if !self.walls.is_empty() {
                    return bad(
                        "walls",
                        "a crystal's box is periodic along every lattice vector: walls go with a box given by `box`".into(),
                    );
                }
            }
            (false, None) => {
                return bad(
                    "box",
                    "missing: give `box: (Lx, Ly, Lz)` or `box: Triclinic(lengths: (Lx, Ly, Lz), tilts: (xy, xz, yz))` (only a Crystal start leaves it out)".into(),
                );
            }
            (false, Some(spec)) => {
                let (x, y, z) = spec.lengths;
                let (low, high) = VALUE_RANGE;
                if ![x, y, z].iter().all(|l| *l >= low && *l <= high) {
                    return bad(
                        "box",
                        format!(
                            "edges must lie in [{low:e}, {high:e}], got ({}, {}, {})",
                            Num(x),
                            Num(y),
                            Num(z)
                        ),
                    );
                }
                let (xy, xz, yz) = spec.tilts;
                if ![xy, xz, yz].iter().all(|t| t.is_finite() && t.abs() <= 1e6) {
                    return bad(
                        "box",
                        format!(
                            "tilts must be finite numbers (at most 1e6 in size), got ({}, {}, {})",
                            Num(xy),
                            Num(xz),
                            Num(yz)
                        ),
                    );
                }
                if spec.is_tilted() && !self.walls.is_empty() {
                    return bad(
                        "walls",
                        "walls close an orthorhombic box only: a tilted box has none".into(),
                    );
                }
            }
        }
        for (i, a) in self.walls.iter().enumerate() {
            if self.walls[..i].contains(a) {
                return bad("walls", format!("{a:?} is listed twice"));
            }
        }
        Ok(())
    }

    /// The species: names, counts, masses, sizes.
    fn validate_species(&self) -> Result<(), (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        if self.species.is_empty() {
            return bad("species", "at least one species is needed".into());
        }
        if self.species.len() > MAX_SPECIES {
            return bad(
                "species",
                format!(
                    "{} species: at most {MAX_SPECIES} (the tables kept per pair of species grow as its square); for a polydisperse system, give a species `sizes`",
                    self.species.len()
                ),
            );
        }
        for (i, s) in self.species.iter().enumerate() {
            let f = |name: &str| format!("species[{i}].{name}");
            if s.name.trim().is_empty() {
                return bad(&f("name"), "must not be empty".into());
            }
            if self.species[..i].iter().any(|t| t.name == s.name) {
                return bad(&f("name"), format!("\"{}\" is used twice", s.name));
            }
            if s.count == 0 {
                return bad(&f("count"), "must be at least 1".into());
            }
            self.validate_sizes_of(i)?;
            let so_far: usize = self.species[..i].iter().map(|t| t.count).sum();
            if s.count > MAX_PARTICLES - so_far {
                return bad(
                    &f("count"),
                    format!(
                        "{} particles with those before: at most {MAX_PARTICLES} in all (about 1 kB of memory each)",
                        (so_far as u128) + s.count as u128
                    ),
                );
            }
            let (low, high) = VALUE_RANGE;
            // Sizes within the range of lengths, so that squared distances
            // and volumes stay finite and nonzero in every driver.
            let reach = s.shape.bounding_radius();
            if !(low..=high).contains(&reach) {
                return bad(
                    &f("shape"),
                    format!(
                        "the body's bounding radius {} must lie in [{low:e}, {high:e}]",
                        Num(reach)
                    ),
                );
            }
            let volume = s.shape.volume();
            if !(volume.is_normal() && volume >= low.powi(3)) {
                return bad(
                    &f("shape"),
                    format!(
                        "the body's volume {} is below {:e}: the body is too thin to place",
                        Num(volume),
                        low.powi(3)
                    ),
                );
            }
            if !(s.mass >= low && s.mass <= high) {
                return bad(
                    &f("mass"),
                    format!("must lie in [{low:e}, {high:e}], got {:e}", s.mass),
                );
            }
        }
        let n = self.particle_count();
        if n < 2 {
            return bad(
                "species",
                "at least 2 particles are needed in all (counts sum to 1)".into(),
            );
        }
        Ok(())
    }

    /// The start: the crystal, the lattice or random insertion, or the log
    /// resumed from; the box against the largest body. The starting box
    /// (a crystal's built once), for the stages.
    fn validate_start(&self) -> Result<PeriodicBox, (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        let crystal = matches!(self.start, Start::Crystal { .. });
        let n = self.particle_count();
        if let Some(built) = self.crystal_sites() {
            match built {
                Err(e) => return bad("start", e.to_string()),
                Ok((box_, _)) => {
                    // The supercell is a box like any other: its edges lie
                    // in the range a box given by `box` must.
                    let l = box_.lengths();
                    let (low, high) = VALUE_RANGE;
                    if !l.iter().all(|l| (low..=high).contains(l)) {
                        return bad(
                            "start",
                            format!(
                                "the crystal's box would have edges ({}, {}, {}), outside \
                                 [{low:e}, {high:e}]: check the bodies' sizes and the \
                                 packing fraction",
                                Num(l.x),
                                Num(l.y),
                                Num(l.z)
                            ),
                        );
                    }
                }
            }
        }
        let diameter = 2.0 * self.largest_bounding_radius();
        let box_ = self.periodic_box();
        let shortest = box_.heights().min();
        if shortest < 2.0 * diameter {
            let (what, field) = match (crystal, box_.is_tilted()) {
                (true, _) => ("the supercell's smallest height", "start"),
                (false, true) => ("the box's smallest height", "box"),
                (false, false) => ("the shortest edge", "box"),
            };
            return bad(
                field,
                format!(
                    "{what} {} must be at least twice the largest bounding diameter {} (minimum image){}",
                    Num(shortest),
                    Num(diameter),
                    if crystal { ": take more cells" } else { "" }
                ),
            );
        }
        let phi0 = self.particle_volume() / box_.volume();
        match &self.start {
            Start::Lattice | Start::Layered(_) => {
                let spaced = self.lattice_species();
                let plan = crate::state::start::lattice_plan(&self.box_vector(), &spaced, n);
                if plan.sites.iter().product::<usize>() < n {
                    let w = plan.spacing;
                    return bad(
                        "start",
                        format!(
                            "a lattice in this box holds {} particles (sites {:.4} x {:.4} x {:.4} apart, the bodies aligned), the species have {n}: enlarge the box",
                            plan.capacity, w.x, w.y, w.z
                        ),
                    );
                }
            }
            Start::Random => {
                if phi0 > 0.25 {
                    return bad(
                        "start",
                        format!(
                            "random insertion at packing fraction {phi0:.3} would rarely succeed (at most 0.25): enlarge the box and compress"
                        ),
                    );
                }
            }
            Start::Resume(path) => {
                if path.trim().is_empty() {
                    return bad("start", "Resume needs the path of a log".into());
                }
            }
            Start::Crystal { .. } => {}
        }
        for (i, st) in self.stages.iter().enumerate() {
            if let Stage::MonteCarlo { ensemble, .. } = st {
                if let Ensemble::Npt {
                    anisotropic: true,
                    box_moves: Some(moves),
                    ..
                } = ensemble
                    && *moves != BoxMoves::Axes
                {
                    return bad(
                        &format!("stages[{i}].ensemble.box_moves"),
                        format!(
                            "{moves:?} contradicts `anisotropic: true` (which is Axes): give one of them"
                        ),
                    );
                }
                match ensemble.box_moves() {
                    Some(BoxMoves::Axes) if self.walls.len() == 3 => {
                        return bad(
                            "walls",
                            "a box closed by walls on every axis has no periodic direction for per-axis box moves".into(),
                        );
                    }
                    Some(BoxMoves::Triclinic) if !self.walls.is_empty() => {
                        return bad(
                            &format!("stages[{i}].ensemble.box_moves"),
                            "Triclinic box moves shear the box, and walls close an orthorhombic box only: use Axes or Isotropic with walls".into(),
                        );
                    }
                    _ => {}
                }
            }
        }
        Ok(box_)
    }

    /// The stages, in order, with the packing fraction each starts from
    /// where it is known before running (from `box_`, the starting box).
    fn validate_stages(&self, box_: &PeriodicBox) -> Result<(), (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        let diameter = 2.0 * self.largest_bounding_radius();
        let shortest = box_.heights().min();
        let phi0 = self.particle_volume() / box_.volume();
        // The contact-time search needs every pair's exact distance: a
        // polyhedron, a spheropolyhedron or a spherocylinder has it (GJK
        // between polytope cores, or closed forms) with spheres, cuboids
        // and each other; with a curved body GJK converges only linearly.
        use crate::geometry::Shape;
        let cored = (self.species.iter()).find(|s| {
            matches!(
                s.shape,
                Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_)
            )
        });
        let curved = (self.species.iter())
            .find(|s| matches!(s.shape, Shape::Ellipsoid(_) | Shape::Superellipsoid(_)));
        if self.stages.is_empty() {
            return bad("stages", "at least one stage is needed".into());
        }
        let densest = self.densest_packing_fraction();
        // The packing fraction as far as it is known before running: the
        // start's, until a stage at fixed pressure makes it unknown.
        let mut known_phi = match self.start {
            Start::Resume(_) => None,
            _ => Some(phi0),
        };
        for (i, st) in self.stages.iter().enumerate() {
            let f = |name: &str| format!("stages[{i}].{name}");
            if matches!(st, Stage::Dynamics { .. } | Stage::Jam { .. })
                && let (Some(cored), Some(curved)) = (cored, curved)
            {
                return bad(
                    &format!("stages[{i}]"),
                    format!(
                        "species \"{}\" ({}) and \"{}\" ({}) are in one scene: {} stages simulate polyhedra, spheropolyhedra and spherocylinders with spheres, cuboids and each other only so far (their contact times need the pair's exact distance), Monte Carlo stages with every shape",
                        cored.name,
                        cored.shape.kind().replace('_', " "),
                        curved.name,
                        curved.shape.kind().replace('_', " "),
                        st.kind()
                    ),
                );
            }
            match st {
                Stage::Jam {
                    growth_rate,
                    fluid_rate,
                    pressure,
                    packing_fraction,
                } => {
                    for (name, rate) in [("growth_rate", growth_rate), ("fluid_rate", fluid_rate)] {
                        if let Some(rate) = rate
                            && !(rate.is_finite() && (MIN_GROWTH_RATE..=0.1).contains(rate))
                        {
                            return bad(
                                &f(name),
                                format!(
                                    "must lie in [{MIN_GROWTH_RATE:e}, 0.1], got {rate:e}{}",
                                    if *rate < MIN_GROWTH_RATE {
                                        " (slower growth would not jam in any real time)"
                                    } else {
                                        ""
                                    }
                                ),
                            );
                        }
                    }
                    if let Some(p) = pressure
                        && !(p.is_finite() && (MIN_JAM_PRESSURE..=1e14).contains(p))
                    {
                        return bad(
                            &f("pressure"),
                            format!(
                                "must lie in [{MIN_JAM_PRESSURE:e}, 1e14] (βPV/N), got {p:e}: fluids and glasses reach βPV/N of tens, so a lower bound would call them jammed (to stop at a density, give packing_fraction)"
                            ),
                        );
                    }
                    if let Some(target) = packing_fraction {
                        packing_target(&f("packing_fraction"), *target, densest, known_phi, true)?;
                    }
                    // The bodies grown to the target (or, jamming, at most
                    // to the densest packing) must still allow the minimum
                    // image in the box.
                    let grown_to = packing_fraction.unwrap_or(densest);
                    let scale = (phi0 / grown_to).cbrt();
                    if shortest * scale < 2.0 * diameter {
                        return bad(
                            &f(if packing_fraction.is_some() {
                                "packing_fraction"
                            } else {
                                "pressure"
                            }),
                            format!(
                                "grown to packing fraction {grown_to:.4} the bodies' largest bounding diameter would be {:.4}, more than half the shortest box edge {:.4} (minimum image): use more particles",
                                Num(diameter / scale),
                                Num(shortest)
                            ),
                        );
                    }
                    known_phi = None;
                }
                Stage::Compress {
                    packing_fraction,
                    pressure,
                    max_sweeps,
                    until_jammed,
                } => {
                    if *max_sweeps == Some(0) {
                        return bad(&f("max_sweeps"), "must be at least 1".into());
                    }
                    self.check_messages(i, max_sweeps.unwrap_or(DEFAULT_COMPRESS_SWEEPS))?;
                    let target = match (packing_fraction, pressure) {
                        (Some(_), Some(_)) | (None, None) => {
                            return bad(
                                &f("packing_fraction"),
                                "give exactly one of packing_fraction and pressure".into(),
                            );
                        }
                        (None, Some(p)) => {
                            let (low, high) = VALUE_RANGE;
                            if !(*p >= low && *p <= high) {
                                return bad(
                                    &f("pressure"),
                                    format!("must lie in [{low:e}, {high:e}]; got {}", Num(*p)),
                                );
                            }
                            if !self.walls.is_empty() {
                                return bad(
                                    &f("pressure"),
                                    "a pressure target is measured by the scale distribution, which has no wall term (with walls it reads low: 3 where the force on the walls says 3.7); compress to a packing_fraction, then MonteCarlo(ensemble: Npt(pressure: ...)) holds a pressure".into(),
                                );
                            }
                            if *until_jammed {
                                return bad(
                                    &f("until_jammed"),
                                    "applies to a packing_fraction target, not a pressure".into(),
                                );
                            }
                            known_phi = None;
                            continue;
                        }
                        (Some(target), None) => target,
                    };
                    packing_target(&f("packing_fraction"), *target, densest, known_phi, false)?;
                    // The box edge at the target must still allow the minimum image.
                    let scale = (phi0 / target).cbrt();
                    if shortest * scale < 2.0 * diameter {
                        return bad(
                            &f("packing_fraction"),
                            format!(
                                "at {target} the shortest box edge would be {:.4}, below twice the largest bounding diameter {:.4}: use more particles",
                                Num(shortest * scale),
                                Num(diameter)
                            ),
                        );
                    }
                    known_phi = Some(*target);
                }
                Stage::MonteCarlo {
                    ensemble,
                    sweeps,
                    tune_sweeps,
                    pressure_tensor,
                    swaps,
                } => {
                    if *sweeps == 0 {
                        return bad(&f("sweeps"), "must be at least 1".into());
                    }
                    self.validate_swaps(&f("swaps"), *swaps)?;
                    if *pressure_tensor && !self.walls.is_empty() {
                        return bad(
                            &f("pressure_tensor"),
                            "the scale distribution has no wall term, so between walls it is not the pressure: measure the tensor in a periodic box".into(),
                        );
                    }
                    self.check_messages(i, *sweeps)?;
                    if let Some(t) = tune_sweeps
                        && t > sweeps
                    {
                        return bad(
                            &f("tune_sweeps"),
                            format!("{t} is more than the stage's {sweeps} sweeps"),
                        );
                    }
                    if let Ensemble::Npt { pressure, .. } = ensemble {
                        let (low, high) = VALUE_RANGE;
                        if !(*pressure >= low && *pressure <= high) {
                            return bad(
                                &f("ensemble.pressure"),
                                format!("must lie in [{low:e}, {high:e}], got {pressure:e}"),
                            );
                        }
                        known_phi = None;
                    }
                }
                Stage::Dynamics {
                    duration,
                    temperature,
                    stats_every,
                    frames_every,
                    ..
                } => {
                    if !(duration.is_finite() && *duration > 0.0) {
                        return bad(
                            &f("duration"),
                            format!("must be finite and > 0, got {}", Num(*duration)),
                        );
                    }
                    let (low, high) = VALUE_RANGE;
                    if !(*temperature >= low && *temperature <= high) {
                        return bad(
                            &f("temperature"),
                            format!("must lie in [{low:e}, {high:e}], got {temperature:e}"),
                        );
                    }
                    for (name, v, most) in [
                        ("stats_every", stats_every, MAX_STATS_PER_STAGE),
                        ("frames_every", frames_every, MAX_FRAMES_PER_STAGE),
                    ] {
                        if let Some(v) = v {
                            if !(v.is_finite() && *v > 0.0) {
                                return bad(
                                    &f(name),
                                    format!("must be finite and > 0, got {}", Num(*v)),
                                );
                            }
                            if duration / v > most {
                                return bad(
                                    &f(name),
                                    format!(
                                        "{v:e} would write {:.3e} messages over the duration {}: at most {most:e} per stage",
                                        duration / v,
                                        Num(*duration)
                                    ),
                                );
                            }
                        }
                    }
                    // The fastest thermal speed against the smallest body.
                    let lightest = self.species.iter().map(|s| s.mass).fold(f64::MAX, f64::min);
                    let smallest = self
                        .species
                        .iter()
                        .map(|s| s.shape.volume().cbrt())
                        .fold(f64::MAX, f64::min);
                    let travelled = duration * (temperature / lightest).sqrt() / smallest;
                    if travelled.is_nan() || travelled > MAX_SIZES_TRAVELLED {
                        return bad(
                            &f("duration"),
                            format!(
                                "at kT = {temperature:e} the lightest body (mass {lightest:e}) would travel {travelled:.3e} times the smallest body size {smallest:e} (cube root of its volume): at most {MAX_SIZES_TRAVELLED:e} in one stage"
                            ),
                        );
                    }
                }
            }
        }
        Ok(())
    }

    /// The log: its path and cadence.
    fn validate_log(&self) -> Result<(), (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        if self.log.path.trim().is_empty() {
            return bad("log.path", "must not be empty".into());
        }
        if self.log.path.ends_with('/') || self.log.path.ends_with(std::path::MAIN_SEPARATOR) {
            return bad(
                "log.path",
                format!(
                    "\"{}\" ends in a separator: a log path names a file",
                    self.log.path
                ),
            );
        }
        // What the file systems refuse, refused here with the reason: a
        // NUL ends a C path, and names are at most 255 bytes (paths 4096).
        if self.log.path.contains('\0') {
            return bad("log.path", "contains a NUL character".into());
        }
        let longest = self.log.path.split('/').map(str::len).max().unwrap_or(0);
        if self.log.path.len() > 4096 || longest + ".partial.resuming".len() > 255 {
            return bad(
                "log.path",
                format!(
                    "a path of {} bytes with a name of {longest}: at most 4096 and, with the .partial.resuming the writer adds, 255",
                    self.log.path.len()
                ),
            );
        }
        if self.log.stats_every == 0 {
            return bad("log.stats_every", "must be at least 1 sweep".into());
        }
        if self.log.frames_every == 0 {
            return bad("log.frames_every", "must be at least 1 sweep".into());
        }
        Ok(())
    }

    /// The accuracy settings of the dynamics.
    fn validate_accuracy(&self) -> Result<(), (String, String)> {
        let bad = |field: &str, message: String| Err((field.to_string(), message));
        let a = &self.accuracy;
        if !(a.grazing_threshold > 0.0 && a.grazing_threshold < 1.0) {
            return bad(
                "accuracy.grazing_threshold",
                format!("must lie in (0, 1), got {}", Num(a.grazing_threshold)),
            );
        }
        if !(a.contact_tolerance > 0.0 && a.contact_tolerance < a.grazing_threshold) {
            return bad(
                "accuracy.contact_tolerance",
                format!(
                    "must lie in (0, grazing_threshold = {}), got {}",
                    Num(a.grazing_threshold),
                    Num(a.contact_tolerance)
                ),
            );
        }
        if !(a.newton_tolerance > 0.0 && a.newton_tolerance < 1e-3) {
            return bad(
                "accuracy.newton_tolerance",
                format!("must lie in (0, 1e-3), got {}", Num(a.newton_tolerance)),
            );
        }
        if let Neighbours::Lists { shell } = a.neighbours
            && !(shell.is_finite() && shell > 0.0)
        {
            return bad(
                "accuracy.neighbours",
                format!(
                    "the neighbour shell must be a length > 0, got {}",
                    Num(shell)
                ),
            );
        }
        Ok(())
    }
}

/// A stage's packing-fraction `target` (its field `field`): below the
/// densest packing of the shapes, and not below `start`, the packing
/// fraction the stage starts from where it is known (a growth, `grows`,
/// must go above it).
fn packing_target(
    field: &str,
    target: f64,
    densest: f64,
    start: Option<f64>,
    grows: bool,
) -> Result<(), (String, String)> {
    let bad = |message: String| Err((field.to_string(), message));
    if !(target.is_finite() && target > 0.0 && target < densest) {
        return bad(format!(
            "must lie in (0, {densest:.4}), the densest packing of these shapes; got {}",
            Num(target)
        ));
    }
    match start {
        Some(phi) if grows && target <= phi => bad(format!(
            "{} is not above the packing fraction {phi:.4} the stage starts from: nothing to grow",
            Num(target)
        )),
        Some(phi) if target < phi => bad(format!(
            "{} is below the packing fraction {phi:.4} the stage starts from: nothing to compress",
            Num(target)
        )),
        _ => Ok(()),
    }
}
