//! Overlap tests the boolean test could not decide (GJK within rounding of
//! touching), counted for the operation that ran them: a driver runs its
//! sweeps inside [`counting_strains`] and gets back the counts of exactly
//! the tests those sweeps made on that thread (HOOMD's `overlap_err_count`
//! is the precedent). Tests outside any such scope are decided the same
//! way and counted nowhere, so no count can turn up in another operation's
//! report. Counting costs nothing on the decided path.

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
    /// The counts of the innermost [`counting_strains`] running on this
    /// thread, `None` outside every scope.
    static STRAINS: Cell<Option<OverlapStrains>> = const { Cell::new(None) };
}

/// Runs `operation` and returns its result with the overlap strains of the
/// tests it made on this thread. A scope inside another keeps its counts
/// to itself (the inner operation reports them, so the outer one must not
/// count them again); the outer scope goes on counting when it ends, also
/// when `operation` unwinds.
pub fn counting_strains<R>(operation: impl FnOnce() -> R) -> (R, OverlapStrains) {
    struct Resume(Option<OverlapStrains>);
    impl Drop for Resume {
        fn drop(&mut self) {
            STRAINS.with(|s| s.set(self.0));
        }
    }
    let _outer = Resume(STRAINS.with(|s| s.replace(Some(OverlapStrains::default()))));
    let result = operation();
    let counted = STRAINS.with(|s| s.get()).unwrap_or_default();
    (result, counted)
}

/// Decides an overlap the boolean test left undecided from the signed
/// `distance` (touching counts as overlap; a failed distance, NaN, counts
/// as overlap too), and counts it.
pub(super) fn settle(distance: f64) -> bool {
    STRAINS.with(|s| {
        if let Some(mut c) = s.get() {
            if distance.is_nan() {
                c.taken_as_overlap += 1;
            } else {
                c.settled_by_distance += 1;
            }
            s.set(Some(c));
        }
    });
    distance.is_nan() || distance <= 0.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::pair::{overlap, smooth_smooth};
    use crate::geometry::{DistanceOptions, Relative, Shape};
    use nalgebra::{UnitQuaternion, Vector3};

    fn ball() -> Shape {
        "Superellipsoid(a: 0.5, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))"
            .parse()
            .unwrap()
    }

    /// The poses of two superballs bisected to touching within rounding,
    /// where GJK is left undecided.
    fn bisected_poses() -> Vec<Relative> {
        let ball = ball();
        let qa = UnitQuaternion::from_euler_angles(0.3, 0.1, 0.2);
        let qb = UnitQuaternion::from_euler_angles(0.5, 0.9, 0.4);
        let dir = Vector3::new(0.6, 0.5, 0.3).normalize();
        let (mut lo, mut hi) = (0.0, 4.0);
        let mut poses = Vec::new();
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            let rel = Relative::new(&(dir * mid), &qa, &qb);
            if overlap(&ball, &ball, &rel) {
                lo = mid;
            } else {
                hi = mid;
            }
            poses.push(rel);
        }
        poses
    }

    /// Bisecting the touching distance of two superballs down to rounding
    /// makes GJK undecided; each such test is counted by the scope it ran
    /// in and settled by the distance's sign.
    #[test]
    fn undecided_tests_are_counted_and_settled_by_the_distance() {
        let ball = ball();
        let mut total = OverlapStrains::default();
        for rel in bisected_poses() {
            let (answer, counted) = counting_strains(|| overlap(&ball, &ball, &rel));
            if counted.any() {
                // Undecided by GJK: the answer is the distance's.
                let d =
                    smooth_smooth::distance(&ball, &ball, &rel, &DistanceOptions::default(), None);
                assert_eq!(answer, d.distance.is_nan() || d.distance <= 0.0);
                assert_eq!(counted.settled_by_distance + counted.taken_as_overlap, 1);
            }
            total += counted;
        }
        assert!(total.settled_by_distance > 0, "{total:?}");
        assert!(
            total
                .in_words()
                .unwrap()
                .contains("settled by the distance")
        );
    }

    /// Tests made outside a scope are counted by none, so they never reach
    /// a later operation's report; a scope inside another keeps its counts
    /// to itself, and the outer one counts on after it (also after a panic
    /// inside).
    #[test]
    fn each_scope_counts_only_its_own_tests() {
        let ball = ball();
        let poses = bisected_poses();
        let undecided = || {
            poses
                .iter()
                .filter(|rel| overlap(&ball, &ball, rel))
                .count()
        };
        let ((), alone) = counting_strains(|| {
            undecided();
        });
        assert!(
            alone.any(),
            "the poses must strain GJK for this test to mean anything"
        );
        // Outside any scope: counted nowhere, not even by the next scope.
        undecided();
        let ((), next) = counting_strains(|| ());
        assert_eq!(next, OverlapStrains::default());
        // Nested: the outer scope counts its own tests before and after
        // the inner one, not the inner one's.
        let (inner, outer) = counting_strains(|| {
            undecided();
            let ((), inner) = counting_strains(|| {
                undecided();
            });
            let unwound = std::panic::catch_unwind(|| {
                counting_strains(|| {
                    undecided();
                    panic!("an operation that fails part way");
                })
            });
            assert!(unwound.is_err());
            undecided();
            inner
        });
        assert_eq!(inner, alone);
        assert_eq!(outer, alone + alone);
    }
}
