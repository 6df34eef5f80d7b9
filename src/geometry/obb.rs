//! Oriented bounding boxes and their overlap by the 15-axis separating-axis
//! test (De Michele Sec. 3.3.3, eqs. 62–64; Gottschalk's OBB test). The same
//! test is the exact cuboid–cuboid overlap kernel.

use nalgebra::{Matrix3, Vector3};

use super::shape::Shape;

/// Added to |Rᵢⱼ| so that nearly parallel edges, whose cross product is
/// rounding noise, never report a false separation (Ericson, RTCD 4.4.1).
const PARALLEL_GUARD: f64 = 1e-14;

/// An oriented box: centre, unit axes as the columns of `axes`, half-extents
/// along those axes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Obb {
    /// Centre of the box.
    pub center: Vector3<f64>,
    /// Columns are the box's unit axes.
    pub axes: Matrix3<f64>,
    /// Half-extents along the axes.
    pub half_extents: Vector3<f64>,
}

impl Obb {
    /// The tight oriented box of `shape` placed at `center` with rotation
    /// matrix `rotation` (body → lab), grown by `shell` on every face (the
    /// Δ_NNL of De Michele eq. 52).
    pub fn of_shape(
        shape: &Shape,
        center: Vector3<f64>,
        rotation: Matrix3<f64>,
        shell: f64,
    ) -> Self {
        Self {
            center,
            axes: rotation,
            half_extents: shape.obb_half_extents().add_scalar(shell),
        }
    }

    /// Whether two boxes overlap (touching counts as overlap).
    pub fn overlaps(&self, other: &Obb) -> bool {
        let rotation = self.axes.tr_mul(&other.axes);
        let translation = self.axes.tr_mul(&(other.center - self.center));
        boxes_overlap(
            &self.half_extents,
            &other.half_extents,
            &rotation,
            &translation,
        )
    }
}

/// Separating-axis test for box A (half-extents `a`, axis-aligned at the
/// origin) and box B (half-extents `b`, centre `t`, axes the columns of `r`),
/// all in A's frame. True when no axis of the 15 separates them.
#[inline]
pub fn boxes_overlap(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> bool {
    let abs_r = r.abs().add_scalar(PARALLEL_GUARD);
    // A's face normals.
    for i in 0..3 {
        let rb = b.x * abs_r[(i, 0)] + b.y * abs_r[(i, 1)] + b.z * abs_r[(i, 2)];
        if t[i].abs() > a[i] + rb {
            return false;
        }
    }
    // B's face normals.
    for j in 0..3 {
        let ra = a.x * abs_r[(0, j)] + a.y * abs_r[(1, j)] + a.z * abs_r[(2, j)];
        let tj = t.x * r[(0, j)] + t.y * r[(1, j)] + t.z * r[(2, j)];
        if tj.abs() > ra + b[j] {
            return false;
        }
    }
    // Edge–edge axes Aᵢ × Bⱼ.
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let ra = a[i1] * abs_r[(i2, j)] + a[i2] * abs_r[(i1, j)];
            let rb = b[j1] * abs_r[(i, j2)] + b[j2] * abs_r[(i, j1)];
            let tl = t[i2] * r[(i1, j)] - t[i1] * r[(i2, j)];
            if tl.abs() > ra + rb {
                return false;
            }
        }
    }
    true
}

/// The largest separation of the two boxes' projections over the 15 axes,
/// with the axis (unit, pointing from A to B). For overlapping boxes this is
/// minus the penetration depth (the minimum translation distance of two
/// convex polyhedra lies along a face normal or an edge–edge cross product);
/// for separated boxes it is a lower bound on their distance.
pub fn max_axis_separation(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> (f64, Vector3<f64>) {
    let (sep, axis, _) = max_axis_separation_with_feature(a, b, r, t);
    (sep, axis)
}

/// Which kind of axis separates two boxes most.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeparatingFeature {
    /// The normal of A's face across axis `i` of A.
    FaceA(usize),
    /// The normal of B's face across axis `j` of B.
    FaceB(usize),
    /// The cross product of A's edge direction `i` and B's `j`.
    Edges(usize, usize),
}

/// [`max_axis_separation`], also saying which axis it is (the contact
/// features of touching boxes: a face of A, a face of B, or two edges).
pub fn max_axis_separation_with_feature(
    a: &Vector3<f64>,
    b: &Vector3<f64>,
    r: &Matrix3<f64>,
    t: &Vector3<f64>,
) -> (f64, Vector3<f64>, SeparatingFeature) {
    // Gottschalk's form: every projection from the entries of R, no axis
    // normalised but the best (the box radii on an axis are linear in it).
    let abs_r = r.abs();
    let mut best = f64::NEG_INFINITY;
    let mut best_axis = (Vector3::x(), 1.0);
    let mut best_feature = SeparatingFeature::FaceA(0);
    // A's face normals eᵢ.
    for i in 0..3 {
        let rb = b.x * abs_r[(i, 0)] + b.y * abs_r[(i, 1)] + b.z * abs_r[(i, 2)];
        let sep = t[i].abs() - a[i] - rb;
        if sep > best {
            best = sep;
            best_axis = (Vector3::ith(i, 1.0), t[i]);
            best_feature = SeparatingFeature::FaceA(i);
        }
    }
    // B's face normals Rⱼ.
    for j in 0..3 {
        let ra = a.x * abs_r[(0, j)] + a.y * abs_r[(1, j)] + a.z * abs_r[(2, j)];
        let tj = t.x * r[(0, j)] + t.y * r[(1, j)] + t.z * r[(2, j)];
        let sep = tj.abs() - ra - b[j];
        if sep > best {
            best = sep;
            best_axis = (r.column(j).into_owned(), tj);
            best_feature = SeparatingFeature::FaceB(j);
        }
    }
    // Edge–edge axes eᵢ × Rⱼ = (component i1: −R_{i2 j}, i2: R_{i1 j}),
    // of length √(R_{i1 j}² + R_{i2 j}²); B's radius on it from
    // Rₗ·(eᵢ × Rⱼ) = eᵢ·(Rⱼ × Rₗ) = ±R_{i m}.
    for i in 0..3 {
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        for j in 0..3 {
            // (Entries of a rotation: no overflow to guard against, so
            // not the slow libm hypot.)
            let len = (r[(i1, j)] * r[(i1, j)] + r[(i2, j)] * r[(i2, j)]).sqrt();
            if len < 1e-9 {
                continue; // parallel edges: the face axes cover this direction
            }
            let (j1, j2) = ((j + 1) % 3, (j + 2) % 3);
            let ra = a[i1] * abs_r[(i2, j)] + a[i2] * abs_r[(i1, j)];
            let rb = b[j1] * abs_r[(i, j2)] + b[j2] * abs_r[(i, j1)];
            let proj = t[i2] * r[(i1, j)] - t[i1] * r[(i2, j)];
            // (sep / len > best, without a division per axis.)
            let sep = proj.abs() - ra - rb;
            if sep > best * len {
                best = sep / len;
                let mut axis = Vector3::zeros();
                axis[i1] = -r[(i2, j)] / len;
                axis[i2] = r[(i1, j)] / len;
                best_axis = (axis, proj);
                best_feature = SeparatingFeature::Edges(i, j);
            }
        }
    }
    let (axis, proj) = best_axis;
    (best, if proj >= 0.0 { axis } else { -axis }, best_feature)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    #[test]
    fn edge_edge_separation_needs_cross_axes() {
        // Two unit cubes, B turned 45° about z and about x, placed along the
        // diagonal so that only an edge–edge axis separates them.
        let a = Vector3::repeat(0.5);
        let r = *Rotation3::from_euler_angles(
            std::f64::consts::FRAC_PI_4,
            0.0,
            std::f64::consts::FRAC_PI_4,
        )
        .matrix();
        let far = Vector3::new(3.0, 3.0, 0.0);
        assert!(!boxes_overlap(&a, &a, &r, &far));
        assert!(boxes_overlap(&a, &a, &r, &Vector3::new(0.9, 0.0, 0.0)));
    }

    #[test]
    fn penetration_depth_of_aligned_boxes() {
        let a = Vector3::new(1.0, 1.0, 1.0);
        let (sep, axis) =
            max_axis_separation(&a, &a, &Matrix3::identity(), &Vector3::new(1.9, 0.1, 0.0));
        assert!((sep + 0.1).abs() < 1e-12);
        assert!((axis - Vector3::x()).norm() < 1e-12);
    }

    /// The entries-of-R form agrees with projecting both boxes on each of
    /// the 15 axes, normalised, one by one; and the axis returned, pointing
    /// from A to B, has that separation.
    #[test]
    fn separation_matches_the_axes_one_by_one() {
        let mut u = crate::test_support::uniform(21);
        let radius = |l: &Vector3<f64>, h: &Vector3<f64>| h.dot(&l.abs());
        for case in 0..2000 {
            let a = Vector3::new(0.1 + u(), 0.1 + u(), 0.1 + u());
            let b = Vector3::new(0.1 + u(), 0.1 + u(), 0.1 + u());
            let r = if case % 10 == 0 {
                Matrix3::identity() // parallel edges: cross axes skipped
            } else {
                *Rotation3::from_euler_angles(7.0 * u(), 7.0 * u(), 7.0 * u()).matrix()
            };
            let t = Vector3::new(u() - 0.5, u() - 0.5, u() - 0.5) * 6.0;
            let mut axes: Vec<Vector3<f64>> = (0..3).map(|i| Vector3::ith(i, 1.0)).collect();
            axes.extend((0..3).map(|j| r.column(j).into_owned()));
            for i in 0..3 {
                for j in 0..3 {
                    let c = Vector3::<f64>::ith(i, 1.0).cross(&r.column(j));
                    if c.norm() >= 1e-9 {
                        axes.push(c.normalize());
                    }
                }
            }
            let along =
                |l: &Vector3<f64>| t.dot(l).abs() - radius(l, &a) - radius(&(r.tr_mul(l)), &b);
            let brute = axes.iter().map(along).fold(f64::NEG_INFINITY, f64::max);
            let (sep, axis) = max_axis_separation(&a, &b, &r, &t);
            assert!((sep - brute).abs() < 1e-12, "case {case}: {sep} vs {brute}");
            assert!(
                (axis.norm() - 1.0).abs() < 1e-12 && t.dot(&axis) >= 0.0,
                "case {case}"
            );
            assert!((along(&axis) - sep).abs() < 1e-12, "case {case}: axis");
        }
    }

    #[test]
    fn shell_grows_the_box() {
        let s = Shape::Sphere(crate::geometry::Sphere::new(1.0).unwrap());
        let a = Obb::of_shape(&s, Vector3::zeros(), Matrix3::identity(), 0.1);
        let b = Obb::of_shape(&s, Vector3::new(2.15, 0.0, 0.0), Matrix3::identity(), 0.1);
        assert!(a.overlaps(&b));
        let c = Obb::of_shape(&s, Vector3::new(2.25, 0.0, 0.0), Matrix3::identity(), 0.1);
        assert!(!a.overlaps(&c));
    }
}
