//! Box moves of NPT Monte Carlo: the box scaled in ln V, or one axis in
//! ln L, with the NPT weight; every centre scales with it.

use rand::Rng;

use crate::state::System;

/// A box move in ln V (isotropic) or in ln Lₖ of a random axis k, accepted
/// with min(1, exp(−βP ΔV + (N+1) ln(V′/V))) when it creates no overlap.
/// The random number is drawn first, so rejected moves skip the overlap
/// check.
pub fn box_move<R: Rng>(
    system: &mut System,
    pressure: f64,
    size: f64,
    anisotropic: bool,
    rng: &mut R,
) -> bool {
    let old = system.box_.lengths();
    let v = old.product();
    let delta = size * (2.0 * rng.r#gen::<f64>() - 1.0);
    let mut lengths = old;
    if anisotropic {
        let k = rng.gen_range(0..3);
        lengths[k] *= delta.exp();
    } else {
        lengths *= (delta / 3.0).exp();
    }
    let v_new = lengths.product();
    let log_acc = -pressure * (v_new - v) + (system.len() as f64 + 1.0) * (v_new / v).ln();
    if log_acc < 0.0 && rng.r#gen::<f64>() >= log_acc.exp() {
        return false;
    }
    system.try_rescale(lengths)
}
