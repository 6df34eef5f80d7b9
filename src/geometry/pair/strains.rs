//! Overlap tests the boolean test could not decide (GJK within rounding of
//! touching), counted per thread: the Monte Carlo driver takes the counts
//! of the tests it ran after its sweeps (HOOMD's `overlap_err_count` is
//! the precedent). Counting costs nothing on the decided path.

use std::cell::Cell;

/// Undecided overlap tests and how they ended.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct OverlapStrains {
    /// Settled by the signed distance (Newton–Raphson, GJK/EPA).
    pub settled_by_distance: u64,
    /// Undecided by the distance too (it failed): taken as an overlap, so
    /// that no move is accepted on an undecided test.
    pub taken_as_overlap: u64,
}

impl OverlapStrains {
    /// Whether any test was undecided.
    pub fn any(&self) -> bool {
        self.settled_by_distance + self.taken_as_overlap > 0
    }

    /// The counts in words, if any.
    pub fn in_words(&self) -> Option<String> {
        self.any().then(|| {
            format!(
                "{} overlap tests undecided by GJK and settled by the distance, {} undecided by both and taken as overlaps",
                self.settled_by_distance, self.taken_as_overlap
            )
        })
    }
}

impl std::ops::Add for OverlapStrains {
    type Output = Self;
    fn add(self, o: Self) -> Self {
        Self {
            settled_by_distance: self.settled_by_distance + o.settled_by_distance,
            taken_as_overlap: self.taken_as_overlap + o.taken_as_overlap,
        }
    }
}

impl std::ops::AddAssign for OverlapStrains {
    fn add_assign(&mut self, o: Self) {
        *self = *self + o;
    }
}

impl std::ops::Sub for OverlapStrains {
    type Output = Self;
    fn sub(self, o: Self) -> Self {
        Self {
            settled_by_distance: self.settled_by_distance - o.settled_by_distance,
            taken_as_overlap: self.taken_as_overlap - o.taken_as_overlap,
        }
    }
}

thread_local! {
    static STRAINS: Cell<OverlapStrains> = const { Cell::new(OverlapStrains {
        settled_by_distance: 0,
        taken_as_overlap: 0,
    }) };
}

/// The strains counted on this thread since the last call, and zero.
pub fn take_overlap_strains() -> OverlapStrains {
    STRAINS.with(|s| s.replace(OverlapStrains::default()))
}

/// Decides an overlap the boolean test left undecided from the signed
/// `distance` (touching counts as overlap; a failed distance, NaN, counts
/// as overlap too), and counts it.
pub(super) fn settle(distance: f64) -> bool {
    STRAINS.with(|s| {
        let mut c = s.get();
        if distance.is_nan() {
            c.taken_as_overlap += 1;
        } else {
            c.settled_by_distance += 1;
        }
        s.set(c);
    });
    distance.is_nan() || distance <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pair::{overlap, smooth_smooth};
    use crate::geometry::{DistanceOptions, Relative, Shape};
    use nalgebra::{UnitQuaternion, Vector3};

    /// Bisecting the touching distance of two superballs down to rounding
    /// makes GJK undecided; each such test is counted and settled by the
    /// distance's sign, and taking the counts zeroes them.
    #[test]
    fn undecided_tests_are_counted_and_settled_by_the_distance() {
        let ball: Shape = "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))"
            .parse()
            .unwrap();
        let qa = UnitQuaternion::from_euler_angles(0.3, 0.1, 0.2);
        let qb = UnitQuaternion::from_euler_angles(0.5, 0.9, 0.4);
        let dir = Vector3::new(0.6, 0.5, 0.3).normalize();
        take_overlap_strains();
        let mut total = OverlapStrains::default();
        let (mut lo, mut hi) = (0.0, 4.0);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            let rel = Relative::new(&(dir * mid), &qa, &qb);
            let answer = overlap(&ball, &ball, &rel);
            let counted = take_overlap_strains();
            if counted.any() {
                // Undecided by GJK: the answer is the distance's.
                let d =
                    smooth_smooth::distance(&ball, &ball, &rel, &DistanceOptions::default(), None);
                assert_eq!(answer, d.distance.is_nan() || d.distance <= 0.0);
                assert_eq!(counted.settled_by_distance + counted.taken_as_overlap, 1);
            }
            total += counted;
            if answer {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        assert!(total.settled_by_distance > 0, "{total:?}");
        assert_eq!(take_overlap_strains(), OverlapStrains::default());
        assert!(
            total
                .in_words()
                .unwrap()
                .contains("settled by the distance")
        );
    }
}
