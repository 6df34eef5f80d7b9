//! Which neighbour structure a configuration uses, and its upkeep as
//! particles move: cells, per-species grids, AABB cells, and the Verlet
//! lists of spheres and of bounding capsules.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use crate::geometry::Placed;
use crate::geometry::capsule::bounding_capsule;
use crate::space::capsule_lists::Segment;
use crate::space::{AabbCells, CapsuleLists, PackedCells, PeriodicBox, SphereLists};

use super::*;

type V3 = Vector3<f64>;

/// How candidate neighbours are found, chosen from the species (the plan):
/// cells as wide as the largest interaction range with the 27-cell stencil
/// for near-isotropic particles of similar size; AABB cells, much smaller,
/// for elongated or flat particles; one grid per species, each as wide as
/// that species' diameter, for size-asymmetric mixtures (a small particle
/// then looks through small cells of its own kind and the few large cells
/// of the large kind, never through hundreds of small particles binned in
/// a large cell).
#[derive(Debug, Clone)]
pub(crate) enum Neighbours {
    Cells(PackedCells),
    Aabb(AabbCells),
    PerSpecies(Vec<PackedCells>),
}

/// The neighbour structure Monte Carlo uses for a set of species, and why.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NeighbourPlan {
    /// AABB cells (true) or 27-stencil cells as wide as the range.
    pub aabb_cells: bool,
    /// One grid per species (size-asymmetric mixtures); then `aabb_cells`
    /// is false.
    pub per_species: bool,
    /// Width of the AABB cells.
    pub aabb_width: f64,
    /// Some species is elongated or flat (bounding radius > 1.5 × its
    /// smallest half-extent).
    pub elongated: bool,
    /// The smallest bounding diameter is under half the interaction range.
    pub size_asymmetric: bool,
    /// Spheres on one grid: the skin of their Verlet lists
    /// ([`SphereLists`]), the smallest radius times [`SPHERE_SKIN`].
    pub sphere_skin: Option<f64>,
    /// AABB cells: the padding of the reference capsules of their Verlet
    /// lists ([`CapsuleLists`]), the smallest thickness times
    /// [`CAPSULE_PAD`].
    pub capsule_pad: Option<f64>,
}

impl NeighbourPlan {
    /// The structure the species call for.
    pub fn for_species(species: &[Species]) -> Self {
        let (aabb_cells, aabb_width, elongated, size_asymmetric) = Neighbours::plan(species);
        let aabb_cells = aabb_cells && !size_asymmetric;
        let one_grid = !aabb_cells && !size_asymmetric;
        let smallest = species
            .iter()
            .map(|s| s.shape.bounding_radius())
            .fold(f64::INFINITY, f64::min);
        Self {
            aabb_cells,
            per_species: size_asymmetric,
            aabb_width,
            elongated,
            size_asymmetric,
            sphere_skin: (one_grid && species.iter().all(|s| s.shape.is_sphere()))
                .then_some(SPHERE_SKIN * smallest),
            capsule_pad: (aabb_cells && capsules_fit(species)).then(|| {
                let thinnest = species
                    .iter()
                    .map(|s| 2.0 * s.shape.min_half_extent())
                    .fold(f64::INFINITY, f64::min);
                CAPSULE_PAD * thinnest
            }),
        }
    }
}

impl Neighbours {
    /// The structure the species call for: (AABB cells?, their width,
    /// elongated?, size-asymmetric?).
    pub(super) fn plan(species: &[Species]) -> (bool, f64, bool, bool) {
        let radii: Vec<f64> = species.iter().map(|s| s.shape.bounding_radius()).collect();
        let max_radius = radii.iter().cloned().fold(0.0, f64::max);
        let range = 2.0 * max_radius;
        let smallest = radii.iter().cloned().fold(f64::INFINITY, f64::min);
        let thickness = species
            .iter()
            .map(|s| 2.0 * s.shape.min_half_extent())
            .fold(0.0, f64::max);
        let elongated = species
            .iter()
            .any(|s| s.shape.bounding_radius() > 1.5 * s.shape.min_half_extent());
        let asymmetric = 2.0 * smallest < 0.5 * range;
        let use_aabb = elongated || asymmetric;
        // Cells between the thickness and the range, nearer the thickness:
        // thin enough to separate neighbours, wide enough that a particle
        // spans few of them. Measured on aligned needles (2.5:0.5:0.5,
        // φ = 0.5): t^¾ r^¼ gave 4.3e5 moves/s, t 3.4e5, √(t r) 3.4e5, r 2.3e5.
        (
            use_aabb,
            thickness.powf(0.75) * range.powf(0.25),
            elongated,
            asymmetric,
        )
    }

    #[allow(clippy::too_many_arguments)]
    pub(super) fn build(
        plan: &NeighbourPlan,
        range: f64,
        box_: &PeriodicBox,
        centres: &[V3],
        halves: &[V3],
        kinds: &[u16],
        species_radii: &[f64],
        radii: &[f64],
    ) -> Self {
        if plan.per_species {
            let grids = (0..species_radii.len())
                .map(|s| {
                    let members = centres
                        .iter()
                        .zip(radii)
                        .map(|(c, r)| (*c, *r))
                        .enumerate()
                        .filter(move |(i, _)| kinds[*i] as usize == s);
                    PackedCells::with_members(box_, 2.0 * species_radii[s], centres.len(), members)
                })
                .collect();
            Neighbours::PerSpecies(grids)
        } else if plan.aabb_cells {
            Neighbours::Aabb(AabbCells::new(box_, plan.aabb_width, centres, halves))
        } else {
            Neighbours::Cells(PackedCells::new(box_, range, centres, radii))
        }
    }
}

/// The spheres' Verlet-list skin over the smallest radius. Measured
/// side by side on one core (spheres φ = 0.5, N = 4096, moves tuned to
/// 30 % acceptance; two soaks loading the machine): no lists 2.8–3.2e6
/// moves/s; skins of 1.0 radius 3.7–4.0e6, 1.4 3.0–3.3e6, 2.0 2.3–3.2e6,
/// 0.6 2.1–3.0e6 (moves leave half the skin too often), 0.4 1.6–1.9e6.
pub const SPHERE_SKIN: f64 = 1.0;

/// The padding of the capsule lists' reference capsules over the
/// smallest thickness. Measured side by side on one core (ellipsoids
/// 2.5:0.5:0.5, φ = 0.5, N = 4096, aligned start, moves tuned to 30 %
/// acceptance): pads of 0.25 and 0.35 1.19–1.24e6 moves/s, 0.5
/// 0.97–1.10e6, 0.15 keeps to the cells (the moves are too long for
/// it: 7.6e5); AABB cells alone 8.2–8.5e5.
pub const CAPSULE_PAD: f64 = 0.25;

/// The width of the capsule lists' own cells over that of the AABB cells:
/// they hold the reference capsules' boxes grown by the pad, larger than
/// the bodies'. Measured side by side on one core (N = 4096, φ = 0.5):
/// needles 2.5:0.5:0.5 1.50–1.56e6 moves/s at 1.0, 1.54–1.63e6 at 1.3
/// (1.41e6 at 1.7); oblate 1:1:0.5 2.04e6 at 1.0, 2.29–2.31e6 at 1.3.
pub const CAPSULE_CELLS: f64 = 1.3;

/// The most the bounding capsule of a species may hold over the body's
/// own volume for the capsule lists to be used. Measured side by side
/// (NVT after compression, the same Markov chain either way, lists
/// against AABB cells alone, one core unless said): needles 2.5:0.5:0.5
/// (capsule 1.4 volumes, φ = 0.5, N = 4096) 1.42–1.50x faster on lists,
/// 1.1–1.2x with two threads; oblate ellipsoids 1:1:0.5 (2.0) 1.95x and
/// 1.4–1.7x; N = 1000 (docs/benchmarks/mc-capsule-fit-2026-12-04.md):
/// cubes (2.7, φ = 0.5) 1.7x, 1.45x on two threads at N = 4096; cuboids
/// 0.8:0.5:0.3 (2.6) 1.7x; tetrahedra (8.2, φ = 0.3) 1.16x, 1.06x on two
/// threads; plates 1:1:0.2 (6.9) 1.05x; octahedra (3.1) and superballs
/// of exponents 4 even.
pub const CAPSULE_FIT: f64 = 10.0;

/// Whether every species fills its bounding capsule well enough for the
/// capsule lists (see [`CAPSULE_FIT`]).
pub(super) fn capsules_fit(species: &[Species]) -> bool {
    species
        .iter()
        .all(|s| bounding_capsule(&s.shape).1.volume() <= CAPSULE_FIT * s.shape.volume())
}

/// The capsule lists' slack over their pad: how far a body at rest may
/// have strayed from its reference before it is relisted (then a trial
/// reaches 2 − 0.6 pads). Measured as [`CAPSULE_PAD`]: 0.6 1.22–1.23e6,
/// 1.0 1.19–1.22e6 moves/s (more trials beyond the lists).
pub const CAPSULE_SLACK: f64 = 0.6;

/// Accepted moves per sphere over which the sphere lists are reviewed:
/// after that many in one box they are built if the moves are short
/// enough to repay them, dropped if they no longer are. A box change
/// starts the count afresh: the sphere lists are scaled with the box while
/// the gap they keep allows it, the capsule lists are dropped.
pub(crate) const SPHERE_LISTS_REVIEW: usize = 4;

/// The AABB half-extents of a body with OBB half-extents `h` rotated by `r`.
#[inline]
pub(super) fn aabb_half_extents(r: &Matrix3<f64>, h: &V3) -> V3 {
    r.abs() * h
}

impl System {
    /// Moves particle `i` (the caller has checked that it creates no overlap).
    pub(crate) fn place(
        &mut self,
        i: usize,
        position: V3,
        orientation: UnitQuaternion<f64>,
        rotation: Matrix3<f64>,
    ) {
        self.changed = true;
        let position = self.box_.wrap_near(&position);
        let step = self
            .box_
            .minimum_image_near(&(position - self.positions[i]));
        self.particles[i].position = position;
        self.positions[i] = position;
        let species = self.particles[i].species as usize;
        let (axis_k, capsule) = self.capsules[species];
        // How far the capsule's axis turned, at its ends (read only where
        // capsule lists may come: a sphere's rotation is never touched).
        let turn: V3 = match self.plan.capsule_pad {
            Some(_) => {
                (rotation.column(axis_k) - self.rotations[i].column(axis_k)) * capsule.half_length
            }
            None => V3::zeros(),
        };
        let h = if self.all_spheres {
            // Spheres: orientation, rotation, placed shape and box never change.
            self.aabb[i]
        } else {
            self.particles[i].orientation = orientation;
            self.rotations[i] = rotation;
            self.placed[i] = Placed::new(self.body_shape(i), &rotation);
            let h = aabb_half_extents(&rotation, &self.obb[species]);
            self.aabb[i] = h;
            h
        };
        match &mut self.cells {
            Neighbours::Cells(cells) => {
                cells.update(i, &position);
                if let Some(lists) = &mut self.sphere_lists {
                    lists.moved(i, &position, &self.box_);
                }
            }
            // While the lists are on, their cells stand in for these.
            Neighbours::Aabb(cells) => match &mut self.capsule_lists {
                Some(lists) => {
                    lists.moved(&self.box_, i, &position, &rotation.column(axis_k).into())
                }
                None => cells.update(i, &position, &h),
            },
            Neighbours::PerSpecies(grids) => grids[species].update(i, &position),
        }
        if let Some(skin) = self.plan.sphere_skin {
            self.review_sphere_lists(step.norm_squared(), skin);
        } else if let Some(pad) = self.plan.capsule_pad {
            // How far the segment's ends moved, the farther of the two.
            let shift = (step + turn).norm().max((step - turn).norm());
            self.review_capsule_lists(shift * shift, pad);
        }
    }

    /// Counts an accepted sphere move of squared length `step_sq`; every
    /// [`SPHERE_LISTS_REVIEW`] moves per sphere, builds the lists if the
    /// root-mean-square step is under a quarter of the `skin`, drops them
    /// if it is not. A sphere is relisted when it has wandered half a skin
    /// from its reference, about every (skin / 2)² / ⟨step²⟩ moves: at
    /// least every four moves pays for the lists; dilute spheres, whose
    /// tuned moves are long, keep to the cells. (Moves tuned to 30 %
    /// acceptance, N = 4096, one core: rms step / skin 0.54, 0.30, 0.24,
    /// 0.19 at φ 0.3, 0.4, 0.45, 0.5; lists against cells at φ 0.45
    /// 4.3–4.4e6 against 3.8–4.0e6 moves/s, at φ 0.5 7.5e6 against 5.0e6.)
    pub(super) fn review_sphere_lists(&mut self, step_sq: f64, skin: f64) {
        if let Some(short) = self.moves_short(step_sq, 0.25 * skin) {
            self.keep_sphere_lists(short, skin);
        }
    }

    /// Builds the sphere lists if the moves are `short` and they are not
    /// there, drops them if the moves are not.
    pub(super) fn keep_sphere_lists(&mut self, short: bool, skin: f64) {
        if short && self.sphere_lists.is_none() {
            self.sphere_lists = Some(SphereLists::new(
                &self.box_,
                self.positions.as_slice(),
                &self.body_radii,
                skin,
            ));
        } else if !short {
            self.sphere_lists = None;
        }
    }

    /// Counts an accepted move of squared length `step_sq` in the review
    /// window; once it holds [`SPHERE_LISTS_REVIEW`] moves per particle,
    /// empties it and says whether their root-mean-square length was
    /// under `limit`.
    pub(super) fn moves_short(&mut self, step_sq: f64, limit: f64) -> Option<bool> {
        self.list_window.0 += 1;
        self.list_window.1 += step_sq;
        self.window_verdict(limit)
    }

    /// Once the review window holds [`SPHERE_LISTS_REVIEW`] moves per
    /// particle, empties it and says whether their root-mean-square length
    /// was under `limit`.
    pub(super) fn window_verdict(&mut self, limit: f64) -> Option<bool> {
        let (moves, sum) = self.list_window;
        if moves < SPHERE_LISTS_REVIEW * self.positions.len() {
            return None;
        }
        self.list_window = (0, 0.0);
        Some(sum / (moves as f64) < limit * limit)
    }

    /// Reviews the sphere lists on the window counted so far (moves a
    /// team made with the review deferred): as the last of those moves
    /// would have, had it been made alone.
    pub(crate) fn review_sphere_lists_now(&mut self) {
        if let Some(skin) = self.plan.sphere_skin
            && let Some(short) = self.window_verdict(0.25 * skin)
        {
            self.keep_sphere_lists(short, skin);
        }
    }

    /// As [`System::review_sphere_lists`] for the capsule lists: built if
    /// the root-mean-square shift of a segment's end per accepted move is
    /// under half the `pad` (a body is relisted when an end has strayed
    /// [`CAPSULE_SLACK`] pads, about every (0.6 pad / shift)² moves).
    pub(super) fn review_capsule_lists(&mut self, shift_sq: f64, pad: f64) {
        let Some(short) = self.moves_short(shift_sq, 0.5 * pad) else {
            return;
        };
        if short && self.capsule_lists.is_none() {
            let segments: Vec<Segment> = (0..self.len()).map(|i| self.segment(i)).collect();
            self.capsule_lists = Some(CapsuleLists::new(
                &self.box_,
                &segments,
                pad,
                CAPSULE_SLACK * pad,
                CAPSULE_CELLS * self.plan.aabb_width,
            ));
        } else if !short && self.capsule_lists.take().is_some() {
            // The AABB cells were left as they were when the lists came.
            self.cells = self.neighbours_as_they_are();
        }
    }

    /// The neighbour structure of the plan built for the particles where
    /// they are.
    pub(super) fn neighbours_as_they_are(&self) -> Neighbours {
        let kinds: Vec<u16> = self.particles.iter().map(|p| p.species).collect();
        Neighbours::build(
            &self.plan,
            self.range,
            &self.box_,
            self.positions.as_slice(),
            &self.aabb,
            &kinds,
            &self.radii,
            &self.body_radii,
        )
    }

    /// The core segment of particle `i`'s bounding capsule as it sits.
    pub(super) fn segment(&self, i: usize) -> Segment {
        let (k, capsule) = self.capsules[self.particles[i].species as usize];
        Segment {
            centre: self.positions[i],
            axis: self.rotations[i].column(k).into(),
            half_length: capsule.half_length,
            radius: capsule.radius,
        }
    }
}
