//! The structure of one logged frame (`hardbody analyze --packing`):
//! contacts, rattlers and the backbone, g(r) and S(k), bond order,
//! nematic and cubatic order, in one report the command line prints and
//! the Python package returns.

use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use serde::Serialize;

use super::StateRecord;
use super::read::LogContents;
use crate::analysis::contact_gap::{GapChoice, read_contact_network};
use crate::analysis::order::{cubatic_order, molecular_axis, nematic_director};
use crate::analysis::packing::{ContactNetwork, PackedBody};
use crate::analysis::structure::{
    Rdf, Steinhardt, neighbours, radial_distribution, steinhardt, structure_factor,
};
use crate::geometry::Shape;
use crate::scene::Scene;
use crate::space::periodic_box::BoxError;

/// S(k) sampled at `k`.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StructureFactor {
    /// Wave numbers.
    pub k: Vec<f64>,
    /// S at each.
    pub s: Vec<f64>,
}

/// The nematic order of the bodies with a molecular axis.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Nematic {
    /// S₂, the largest eigenvalue of the Q tensor.
    pub order: f64,
    /// Its eigenvector.
    pub director: [f64; 3],
}

/// The structure of a frame.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PackingReport {
    /// The gap the contacts were read at, and how it was chosen.
    pub gap: GapChoice,
    /// Contacts, rattlers, the backbone and its contact numbers.
    pub network: ContactNetwork,
    /// g(r) of the centres, to just under half the shortest edge (at most
    /// five of the largest bounding diameters).
    pub rdf: Rdf,
    /// S(k) from g(r), to 20π over that diameter.
    pub structure_factor: StructureFactor,
    /// The neighbour distance of the bond order: 1.4 of that diameter
    /// (the first minimum of g(r) of dense spheres).
    pub steinhardt_cutoff: f64,
    /// Q4 and Q6.
    pub steinhardt: Vec<Steinhardt>,
    /// None when no body has a molecular axis.
    pub nematic: Option<Nematic>,
    /// The cubatic order of the cuboids (None without cuboids).
    pub cubatic: Option<f64>,
}

/// The reduced pressure βPV/N a log records for its frame `index`: the
/// `/stats` written with it (a jam stage writes both at each frame).
pub fn reduced_pressure_at(contents: &LogContents, index: usize) -> Option<f64> {
    let (time, state) = contents.states.get(index)?;
    let pressure = contents
        .stats
        .iter()
        .find(|(t, s)| t == time && s.stage_index == state.stage_index)?
        .1
        .pressure?;
    let volume: f64 = state.box_lengths.iter().product();
    Some(pressure * volume / state.positions.len() as f64)
}

impl PackingReport {
    /// The report of frame `index` of a log (the box's walls and the
    /// frame's pressure from the log; see [`PackingReport::of_frame`]).
    /// `None` if there is no such frame.
    pub fn of_log_frame(
        contents: &LogContents,
        index: usize,
        gap: Option<f64>,
    ) -> Option<Result<Self, BoxError>> {
        let (_, state) = contents.states.get(index)?;
        let walls = contents
            .metadata
            .get("scene_resolved")
            .and_then(|text| Scene::parse(text).ok())
            .map(|scene| scene.wall_axes())
            .unwrap_or_default();
        Some(Self::of_frame(
            state,
            walls,
            gap,
            reduced_pressure_at(contents, index),
        ))
    }

    /// The report of `state`, in a box closed by walls on `walls`, with
    /// bodies in contact where their gap is under `gap` of the smaller
    /// one's smallest half-extent, or, without `gap`, under the gap on
    /// the plateau of the contact count ([`read_contact_network`]; `reduced_pressure`,
    /// the frame's βPV/N where known, guides it).
    pub fn of_frame(
        state: &StateRecord,
        walls: [bool; 3],
        gap: Option<f64>,
        reduced_pressure: Option<f64>,
    ) -> Result<Self, BoxError> {
        let box_ = state.periodic_box(walls)?;
        let (shapes, turns, shape_of) = state.body_shapes();
        let bodies: Vec<PackedBody> = state
            .positions
            .iter()
            .zip(&state.orientations)
            .zip(&shape_of)
            .map(|((p, q), &k)| PackedBody {
                position: Vector3::from(*p),
                orientation: UnitQuaternion::from_quaternion(Quaternion::new(
                    q[0], q[1], q[2], q[3],
                )),
                shape: k,
            })
            .collect();
        let (choice, network) =
            read_contact_network(&box_, &shapes, &turns, &bodies, gap, reduced_pressure);
        let centres: Vec<Vector3<f64>> = bodies.iter().map(|b| b.position).collect();
        let diameter = shapes
            .iter()
            .map(|s| 2.0 * s.bounding_radius())
            .fold(0.0, f64::max);
        let r_max = (0.49 * box_.heights().min()).min(5.0 * diameter);
        let rdf = radial_distribution(&box_, &centres, 100, r_max);
        // The peaks of dense packings lie near 2π/σ.
        let (k, s) = structure_factor(
            &rdf,
            centres.len() as f64 / box_.volume(),
            20.0 * std::f64::consts::PI / diameter,
            200,
        );
        let steinhardt_cutoff = 1.4 * diameter;
        let bond_order = steinhardt(&neighbours(&box_, &centres, steinhardt_cutoff), &[4, 6]);
        let axes: Vec<Option<Vector3<f64>>> = shapes.iter().map(molecular_axis).collect();
        let nematic = nematic_director(
            bodies
                .iter()
                .filter_map(|b| axes[b.shape].map(|u| b.orientation * u)),
        )
        .map(|(order, d)| Nematic {
            order,
            director: [d.x, d.y, d.z],
        });
        // The axes of other bodies mean nothing cubic.
        let cubatic = cubatic_order(
            bodies
                .iter()
                .filter(|b| matches!(shapes[b.shape], Shape::Cuboid(_)))
                .map(|b| *b.orientation.to_rotation_matrix().matrix()),
        );
        Ok(Self {
            gap: choice,
            network,
            rdf,
            structure_factor: StructureFactor { k, s },
            steinhardt_cutoff,
            steinhardt: bond_order,
            nematic,
            cubatic,
        })
    }
}
