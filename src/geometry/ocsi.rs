//! Cuboid–sphere overlap: OCSI (Tonti & Patti, Algorithm 5) and its rivals
//! Arvo, QRI, QRF and the branchless SSE-style test (Algorithms 1–4), all on
//! the same inputs so that `hardbody bench ocsi` compares like with like.
//!
//! Convention (as in the paper): `r_sc = r_S − r_C`, the sphere centre
//! relative to the cuboid centre, in any frame in which the cuboid's unit
//! axes `axes` (columns T, L, W) are also given; `half` holds the half-lengths
//! (c_T, c_L, c_W). Touching counts as overlap (d_min ≤ R).

use nalgebra::{Matrix3, Vector3};

/// OCSI, Algorithm 5: lᵢ = max(|r_sc·êᵢ| − cᵢ, 0), overlap iff Σ lᵢ² ≤ R².
#[inline]
pub fn ocsi(r_sc: &Vector3<f64>, radius: f64, axes: &Matrix3<f64>, half: &Vector3<f64>) -> bool {
    let mut d = 0.0;
    for i in 0..3 {
        let l = (r_sc.dot(&axes.column(i)).abs() - half[i]).max(0.0);
        d += l * l;
    }
    d <= radius * radius
}

/// Arvo, Algorithm 1, applied to an oriented cuboid by first expressing the
/// sphere centre in the cuboid frame (where the box is [−c, c]).
#[inline]
pub fn arvo(r_sc: &Vector3<f64>, radius: f64, axes: &Matrix3<f64>, half: &Vector3<f64>) -> bool {
    let local = axes.tr_mul(r_sc);
    let mut d = 0.0;
    for i in 0..3 {
        if local[i] < -half[i] {
            d += (-half[i] - local[i]).powi(2);
        } else if local[i] > half[i] {
            d += (local[i] - half[i]).powi(2);
        }
    }
    d <= radius * radius
}

/// Quick Rejection Intertwined, Algorithm 2: rejects inside the loop as soon
/// as one slab excludes the sphere.
#[inline]
pub fn qri(r_sc: &Vector3<f64>, radius: f64, axes: &Matrix3<f64>, half: &Vector3<f64>) -> bool {
    let mut d = 0.0;
    for i in 0..3 {
        let a = r_sc.dot(&axes.column(i));
        let l = a + half[i];
        if l < 0.0 {
            if l < -radius {
                return false;
            }
            d += l * l;
        } else {
            let l = a - half[i];
            if l > 0.0 {
                if l > radius {
                    return false;
                }
                d += l * l;
            }
        }
    }
    d <= radius * radius
}

/// Quick Rejection First, Algorithm 3: all three slab rejections before the
/// distance is summed.
#[inline]
pub fn qrf(r_sc: &Vector3<f64>, radius: f64, axes: &Matrix3<f64>, half: &Vector3<f64>) -> bool {
    let mut a = [0.0; 3];
    for i in 0..3 {
        a[i] = r_sc.dot(&axes.column(i));
        if a[i] < -half[i] - radius || a[i] > half[i] + radius {
            return false;
        }
    }
    let mut d = 0.0;
    for i in 0..3 {
        if a[i] < -half[i] {
            let l = a[i] + half[i];
            d += l * l;
        } else if a[i] > half[i] {
            let l = a[i] - half[i];
            d += l * l;
        }
    }
    d <= radius * radius
}

/// The branchless SSE-style test, Algorithm 4:
/// lᵢ = min(aᵢ + cᵢ, 0) + max(aᵢ − cᵢ, 0).
#[inline]
pub fn sse(r_sc: &Vector3<f64>, radius: f64, axes: &Matrix3<f64>, half: &Vector3<f64>) -> bool {
    let a = axes.tr_mul(r_sc);
    let mut d = 0.0;
    for i in 0..3 {
        let l = (a[i] + half[i]).min(0.0) + (a[i] - half[i]).max(0.0);
        d += l * l;
    }
    d <= radius * radius
}

/// Exact distance from a point to an axis-aligned box [−c, c] (Tonti & Patti
/// eq. 2), signed: negative inside, where it is minus the distance to the
/// nearest face. Returns the distance and the closest point of the box's
/// surface.
#[inline]
pub fn point_box_distance(p: &Vector3<f64>, half: &Vector3<f64>) -> (f64, Vector3<f64>) {
    let excess = p.abs() - half;
    if excess.max() > 0.0 {
        // Outside: eq. 2, the Heaviside-weighted sum of squared excesses.
        let clamped = Vector3::new(
            p.x.clamp(-half.x, half.x),
            p.y.clamp(-half.y, half.y),
            p.z.clamp(-half.z, half.z),
        );
        (excess.map(|e| e.max(0.0)).norm(), clamped)
    } else {
        // Inside: the nearest face is the one with the largest (least
        // negative) excess.
        let i = excess.imax();
        let mut q = *p;
        q[i] = half[i].copysign(p[i]);
        (excess[i], q)
    }
}

/// Sphere centres and radii as columns (structure of arrays).
#[derive(Debug, Clone, Copy)]
pub struct Spheres<'a> {
    /// x of the centres.
    pub x: &'a [f64],
    /// y of the centres.
    pub y: &'a [f64],
    /// z of the centres.
    pub z: &'a [f64],
    /// Radii.
    pub radius: &'a [f64],
}

/// Many spheres, one cuboid: OCSI written so that the compiler vectorises
/// the loop (no branches, no early exits).
///
/// The spheres are given in the frame in which the cuboid has centre
/// `center` and unit axes `axes` (columns); `out[i]` is set to whether sphere
/// i overlaps. Panics if the columns and `out` differ in length.
///
/// On x86-64 machines with AVX2 and FMA the same loop runs compiled for
/// 4-wide vectors with fused multiply–adds (chosen at run time); elsewhere
/// for the baseline (SSE2, 2-wide).
pub fn ocsi_batch(
    center: &Vector3<f64>,
    axes: &Matrix3<f64>,
    half: &Vector3<f64>,
    spheres: &Spheres,
    out: &mut [bool],
) {
    #[cfg(target_arch = "x86_64")]
    {
        if std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
        {
            // SAFETY: the CPU supports AVX2 and FMA, checked just above.
            unsafe { ocsi_batch_avx2(center, axes, half, spheres, out) };
            return;
        }
    }
    ocsi_batch_kernel::<false>(center, axes, half, spheres, out);
}

#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
fn ocsi_batch_avx2(
    center: &Vector3<f64>,
    axes: &Matrix3<f64>,
    half: &Vector3<f64>,
    spheres: &Spheres,
    out: &mut [bool],
) {
    ocsi_batch_kernel::<true>(center, axes, half, spheres, out);
}

/// The loop; with `FMA` the projections use fused multiply–adds (one
/// rounding instead of two: answers can differ from the scalar test only
/// for spheres within ~1e-16 of contact).
#[inline(always)]
fn ocsi_batch_kernel<const FMA: bool>(
    center: &Vector3<f64>,
    axes: &Matrix3<f64>,
    half: &Vector3<f64>,
    spheres: &Spheres,
    out: &mut [bool],
) {
    let n = out.len();
    let Spheres {
        x: xs,
        y: ys,
        z: zs,
        radius: radii,
    } = *spheres;
    assert!(
        xs.len() == n && ys.len() == n && zs.len() == n && radii.len() == n,
        "ocsi_batch: columns of different lengths"
    );
    let (xs, ys, zs, radii) = (&xs[..n], &ys[..n], &zs[..n], &radii[..n]);
    let e = axes.transpose(); // rows are the cuboid axes
    let (cx, cy, cz) = (center.x, center.y, center.z);
    let (h0, h1, h2) = (half.x, half.y, half.z);
    // `if l > 0 { l } else { 0 }` rather than `f64::max`, whose NaN rule
    // costs extra instructions per lane; positions here are finite.
    let excess = |a: f64, h: f64| {
        let l = a.abs() - h;
        if l > 0.0 { l } else { 0.0 }
    };
    let dot = |dx: f64, dy: f64, dz: f64, k: usize| {
        if FMA {
            dx.mul_add(e[(k, 0)], dy.mul_add(e[(k, 1)], dz * e[(k, 2)]))
        } else {
            dx * e[(k, 0)] + dy * e[(k, 1)] + dz * e[(k, 2)]
        }
    };
    for i in 0..n {
        let (dx, dy, dz) = (xs[i] - cx, ys[i] - cy, zs[i] - cz);
        let l0 = excess(dot(dx, dy, dz, 0), h0);
        let l1 = excess(dot(dx, dy, dz, 1), h1);
        let l2 = excess(dot(dx, dy, dz, 2), h2);
        out[i] = l0 * l0 + l1 * l1 + l2 * l2 <= radii[i] * radii[i];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    #[test]
    fn all_algorithms_agree_with_the_exact_distance() {
        let half = Vector3::new(0.5, 2.0, 4.0);
        let axes =
            *Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 2.0, 3.0)), 0.7)
                .matrix();
        let mut u = crate::test_support::uniform(7);
        let n = 4000;
        let (mut xs, mut ys, mut zs, mut rs) = (vec![], vec![], vec![], vec![]);
        for _ in 0..n {
            xs.push(12.0 * u() - 6.0);
            ys.push(12.0 * u() - 6.0);
            zs.push(12.0 * u() - 6.0);
            rs.push([0.05, 0.5, 5.0][(u() * 3.0) as usize % 3]);
        }
        let mut out = vec![false; n];
        ocsi_batch(
            &Vector3::zeros(),
            &axes,
            &half,
            &Spheres {
                x: &xs,
                y: &ys,
                z: &zs,
                radius: &rs,
            },
            &mut out,
        );
        let mut overlaps = 0;
        for i in 0..n {
            let r = Vector3::new(xs[i], ys[i], zs[i]);
            let (d, _) = point_box_distance(&axes.tr_mul(&r), &half);
            let exact = d <= rs[i];
            overlaps += exact as usize;
            for (name, f) in [
                ("ocsi", ocsi as fn(&_, _, &_, &_) -> bool),
                ("arvo", arvo),
                ("qri", qri),
                ("qrf", qrf),
                ("sse", sse),
            ] {
                assert_eq!(f(&r, rs[i], &axes, &half), exact, "{name} at {r:?}");
            }
            assert_eq!(out[i], exact, "batch at {r:?}");
        }
        assert!(overlaps > n / 10 && overlaps < n * 9 / 10);
    }

    #[test]
    fn point_box_distance_inside_and_outside() {
        let half = Vector3::new(1.0, 2.0, 3.0);
        let (d, q) = point_box_distance(&Vector3::new(4.0, 6.0, 0.0), &half);
        assert!((d - 5.0).abs() < 1e-15);
        assert_eq!(q, Vector3::new(1.0, 2.0, 0.0));
        let (d, q) = point_box_distance(&Vector3::new(0.2, -1.5, 0.0), &half);
        assert!((d + 0.5).abs() < 1e-15);
        assert_eq!(q, Vector3::new(0.2, -2.0, 0.0));
    }
}
