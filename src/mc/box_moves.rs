//! Box moves of NPT Monte Carlo: the box scaled in ln V, stretched along
//! one lab axis in ln L, or sheared in one tilt factor, with the NPT
//! weight; every centre keeps its fractional coordinates.
//!
//! Each move is a deformation of space applied to the box matrix H
//! (H ↦ cH, H ↦ DₖH, H ↦ (1 + εEᵢⱼ)H), so it acts alike on every cell of
//! the same lattice: a box whose tilts pass half an edge can be reduced to
//! the same lattice with the shortest tilts (cells stay valid however far
//! a crystal shears) without breaking detailed balance. The weight is
//! V^N e^{−βPV} dH/(Lx² Ly) over the six entries of H: under it the edges
//! are distributed as in an orthorhombic box (V^N e^{−βPV} dLx dLy dLz)
//! and the tilts, at fixed edges, uniformly over the reduced cell; every
//! ln-scale move then carries (V′/V)^{N+1} and a shear, which keeps the
//! volume, nothing.

use rand::Rng;

use crate::state::System;

/// Which box moves an NPT stage makes.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum BoxMoves {
    /// ln V, every edge scaled alike.
    #[default]
    Isotropic,
    /// ln Lₖ of one edge at a time (a stretch along lab axis k).
    Axes,
    /// Half the moves ln Lₖ of one edge, half one tilt factor sheared.
    Triclinic,
}

/// What a box move was and whether it was kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BoxMoveOutcome {
    /// A shear (else a volume or edge move).
    pub shear: bool,
    /// Kept.
    pub accepted: bool,
}

/// A box move of kind `moves`: ln V or ln Lₖ by up to `volume_size`,
/// accepted with min(1, exp(−βP ΔV + (N+1) ln(V′/V))), or a tilt factor
/// changed by up to `shear_size`, accepted when it creates no overlap.
/// The random number is drawn first, so rejected moves skip the overlap
/// check.
pub fn box_move<R: Rng>(
    system: &mut System,
    pressure: f64,
    (volume_size, shear_size): (f64, f64),
    moves: BoxMoves,
    rng: &mut R,
) -> BoxMoveOutcome {
    let shear = moves == BoxMoves::Triclinic && rng.r#gen::<bool>();
    let old = *system.periodic_box();
    let accepted = if shear {
        let k = rng.gen_range(0..3);
        let mut tilts = old.tilts();
        tilts[k] += shear_size * (2.0 * rng.r#gen::<f64>() - 1.0);
        match old.with_tilts(tilts) {
            Ok(new_box) => system.try_change_box(new_box),
            Err(_) => false,
        }
    } else {
        let v = old.volume();
        let delta = volume_size * (2.0 * rng.r#gen::<f64>() - 1.0);
        let new_box = if moves == BoxMoves::Isotropic {
            old.with_lengths(old.lengths() * (delta / 3.0).exp())
        } else {
            let k = rng.gen_range(0..3);
            old.stretched_along(k, delta.exp())
        };
        match new_box {
            Ok(new_box) => {
                let v_new = new_box.volume();
                let log_acc =
                    -pressure * (v_new - v) + (system.len() as f64 + 1.0) * (v_new / v).ln();
                if log_acc < 0.0 && rng.r#gen::<f64>() >= log_acc.exp() {
                    false
                } else {
                    system.try_change_box(new_box)
                }
            }
            Err(_) => false,
        }
    };
    BoxMoveOutcome { shear, accepted }
}
