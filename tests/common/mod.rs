//! Shared helpers for the tests: random shapes and poses, independent
//! reference methods ("oracles") to check kernels against, the shipped
//! scene files, and logs cut as a crash would leave them.
#![allow(dead_code)]

pub mod polydisperse;

use hardbody::geometry::gjk::{GjkOutcome, gjk_distance, gjk_intersect};
use hardbody::geometry::implicit::SmoothSurface;
use hardbody::geometry::newton::{NewtonOptions, newton_distance};
use hardbody::geometry::roots::brent_minimize;
use hardbody::geometry::{Cuboid, Ellipsoid, Relative, Shape, Sphere, Superellipsoid};
use nalgebra::{Quaternion, UnitQuaternion, Vector3};
use rand::Rng;
use rand_distr::StandardNormal;
use rand_pcg::Pcg64;

pub type V3 = Vector3<f64>;

/// A deterministic generator for case `i` of test `tag`.
pub fn rng(tag: u64, i: u64) -> Pcg64 {
    use rand::SeedableRng;
    Pcg64::seed_from_u64(tag.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ i)
}

pub fn random_rotation(rng: &mut Pcg64) -> UnitQuaternion<f64> {
    let q = Quaternion::new(
        rng.sample::<f64, _>(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
        rng.sample(StandardNormal),
    );
    UnitQuaternion::from_quaternion(q)
}

pub fn random_unit(rng: &mut Pcg64) -> V3 {
    loop {
        let v = V3::new(
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
            rng.sample(StandardNormal),
        );
        if v.norm() > 1e-6 {
            return v.normalize();
        }
    }
}

/// The shape kinds, in dispatch order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    Sphere,
    Ellipsoid,
    Superellipsoid,
    Cuboid,
}

pub const KINDS: [Kind; 4] = [
    Kind::Sphere,
    Kind::Ellipsoid,
    Kind::Superellipsoid,
    Kind::Cuboid,
];

/// A random shape of the kind: sizes within [0.1, 1.5] (aspect ratios up
/// to 15), superellipsoid exponents within [2, 8].
pub fn random_shape(kind: Kind, rng: &mut Pcg64) -> Shape {
    let mut len = || 0.1 + 1.4 * rng.r#gen::<f64>();
    match kind {
        Kind::Sphere => Shape::Sphere(Sphere::new(len()).unwrap()),
        Kind::Ellipsoid => Shape::Ellipsoid(Ellipsoid::new(len(), len(), len()).unwrap()),
        Kind::Superellipsoid => {
            let (a, b, c) = (len(), len(), len());
            let mut e = || 2.0 + 6.0 * rng.r#gen::<f64>();
            Shape::Superellipsoid(Superellipsoid::new(a, b, c, (e(), e(), e())).unwrap())
        }
        Kind::Cuboid => Shape::Cuboid(Cuboid::new(len(), len(), len()).unwrap()),
    }
}

/// B placed at `s·u` in A's frame with relative rotation `q`.
pub fn placed(u: &V3, s: f64, q: &UnitQuaternion<f64>) -> Relative {
    Relative {
        translation: u * s,
        rotation: q.to_rotation_matrix().into_inner(),
    }
}

fn supports<'s>(
    a: &'s Shape,
    b: &'s Shape,
    rel: &'s Relative,
) -> (impl Fn(&V3) -> V3 + 's, impl Fn(&V3) -> V3 + 's) {
    (
        move |d: &V3| a.support(d),
        move |d: &V3| rel.b_to_a(&b.support(&rel.rotation.tr_mul(d))),
    )
}

/// The separation s* along `u` at which A and B (relative rotation `q`)
/// touch, by Newton on GJK's lower bound of the distance d(s) from the far
/// side (d is convex in s and the bound lies below it, so the iteration
/// never overshoots).
pub fn contact_separation(a: &Shape, b: &Shape, u: &V3, q: &UnitQuaternion<f64>) -> f64 {
    let len = a.min_half_extent().min(b.min_half_extent());
    let mut s = a.bounding_radius() + b.bounding_radius();
    for _ in 0..200 {
        let rel = placed(u, s, q);
        let (sa, sb) = supports(a, b, &rel);
        let g = gjk_distance(&sa, &sb, rel.translation, 1e-14 * len, 10_000);
        if g.outcome == GjkOutcome::Overlapping || g.distance < 1e-13 * len {
            break;
        }
        let n = (g.point_b - g.point_a).normalize();
        s -= g.lower_bound / u.dot(&n);
    }
    s
}

/// B placed so that it touches A with common normal `n` (unit, A's frame)
/// and then moved by `delta` along `n`: the support points of A along n and
/// of B along −n coincide before the move, so the plane through them
/// separates the bodies and their distance is exactly `delta` for
/// `delta` ≥ 0; for `delta` < 0 they overlap.
pub fn touching(a: &Shape, b: &Shape, q: &UnitQuaternion<f64>, n: &V3, delta: f64) -> Relative {
    let r = q.to_rotation_matrix().into_inner();
    let pa = a.support(n);
    let pb = r * b.support(&r.tr_mul(&-n));
    Relative {
        translation: pa - pb + n * delta,
        rotation: r,
    }
}

/// GJK overlap with a generous cap, undecided counted as touching.
pub fn gjk_oracle(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let (sa, sb) = supports(a, b, rel);
    gjk_intersect(sa, sb, rel.translation, 100_000).unwrap_or(true)
}

/// min over the cuboid `h` (at the origin) of B's implicit function, B
/// smooth and placed by `rel`: B's interior meets the box iff this is ≤ 0.
/// Convex g on a box: either B's centre is inside, or the minimum lies on a
/// face, found by nested Brent minimisation (partial minima of a convex
/// function are convex).
pub fn box_min_implicit<B: SmoothSurface>(h: &V3, b: &B, rel: &Relative) -> f64 {
    let c = rel.translation;
    if (0..3).all(|i| c[i].abs() <= h[i]) {
        return -1.0;
    }
    let g = |x: &V3| b.implicit(&rel.rotation.tr_mul(&(x - c))).value;
    let mut best = f64::INFINITY;
    for i in 0..3 {
        let (j, k) = ((i + 1) % 3, (i + 2) % 3);
        for sign in [-1.0, 1.0] {
            let inner = |y: f64| {
                brent_minimize(
                    |z| {
                        let mut x = V3::zeros();
                        x[i] = sign * h[i];
                        x[j] = y;
                        x[k] = z;
                        g(&x)
                    },
                    -h[k],
                    h[k],
                    1e-12,
                    200,
                )
                .1
            };
            let (_, m, _) = brent_minimize(inner, -h[j], h[j], 1e-12, 200);
            best = best.min(m);
            if best <= 0.0 {
                return best;
            }
        }
    }
    best
}

/// Overlap of a cuboid (A) and a smooth body (B) by [`box_min_implicit`].
pub fn cuboid_smooth_oracle(a: &Shape, b: &Shape, rel: &Relative) -> bool {
    let Shape::Cuboid(c) = a else {
        panic!("A must be the cuboid")
    };
    let h = c.half_extents();
    match b {
        Shape::Sphere(s) => box_min_implicit(&h, s, rel) <= 0.0,
        Shape::Ellipsoid(e) => box_min_implicit(&h, e, rel) <= 0.0,
        Shape::Superellipsoid(q) => box_min_implicit(&h, q, rel) <= 0.0,
        Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => {
            panic!("B must be smooth")
        }
    }
}

/// Overlap of two smooth bodies by Newton–Raphson alone (no GJK), with a
/// witness search on the centre line for overlaps too deep for Newton.
/// `None` when neither decides.
pub fn newton_oracle(a: &Shape, b: &Shape, rel: &Relative) -> Option<bool> {
    fn inner<A: SmoothSurface>(a: &A, b: &Shape, rel: &Relative) -> Option<bool> {
        match b {
            Shape::Sphere(y) => decide(a, y, rel),
            Shape::Ellipsoid(y) => decide(a, y, rel),
            Shape::Superellipsoid(y) => decide(a, y, rel),
            Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => None,
        }
    }
    fn decide<A: SmoothSurface, B: SmoothSurface>(a: &A, b: &B, rel: &Relative) -> Option<bool> {
        let t = rel.translation;
        for k in 0..=256 {
            let p = t * (k as f64 / 256.0);
            let fb = b.implicit(&rel.rotation.tr_mul(&(p - t))).value;
            if a.implicit(&p).value <= 0.0 && fb <= 0.0 {
                return Some(true);
            }
        }
        let c = newton_distance(a, b, rel, &NewtonOptions::default(), None);
        if c.is_converged() {
            return Some(c.distance <= 0.0);
        }
        // Too deep for a negative-distance solution: look for a common
        // interior point on a 64³ grid over A's bounding box.
        let h = a.semi_axes();
        let m = 64;
        for i in 0..m {
            for j in 0..m {
                for k in 0..m {
                    let f = |n: usize, len: f64| len * (2.0 * (n as f64 + 0.5) / m as f64 - 1.0);
                    let p = V3::new(f(i, h.x), f(j, h.y), f(k, h.z));
                    if a.implicit(&p).value < 0.0
                        && b.implicit(&rel.rotation.tr_mul(&(p - t))).value < 0.0
                    {
                        return Some(true);
                    }
                }
            }
        }
        None
    }
    match a {
        Shape::Sphere(x) => inner(x, b, rel),
        Shape::Ellipsoid(x) => inner(x, b, rel),
        Shape::Superellipsoid(x) => inner(x, b, rel),
        Shape::Cuboid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_) => None,
    }
}

/// The independent reference for the overlap kernel of the pair (a, b):
/// Newton–Raphson for smooth pairs (whose kernels are closed forms,
/// Perram–Wertheim or GJK); nested minimisation of the smooth body's implicit
/// function over the box for cuboid–smooth pairs (OCSI, GJK); GJK, finite
/// and exact on polytopes, for cuboid pairs (separating axes).
pub fn reference_overlap(a: &Shape, b: &Shape, rel: &Relative) -> Option<bool> {
    use Shape::*;
    match (a, b) {
        (Superellipsoid(_), Sphere(_) | Ellipsoid(_) | Superellipsoid(_))
        | (Sphere(_) | Ellipsoid(_), Superellipsoid(_)) => newton_oracle(a, b, rel),
        (Cuboid(_), Sphere(_) | Ellipsoid(_) | Superellipsoid(_)) => {
            Some(cuboid_smooth_oracle(a, b, rel))
        }
        (Sphere(_) | Ellipsoid(_) | Superellipsoid(_), Cuboid(_)) => {
            Some(cuboid_smooth_oracle(b, a, &rel.inverse()))
        }
        (Cuboid(_), Cuboid(_)) | (Spherocylinder(_), _) | (_, Spherocylinder(_)) => {
            Some(gjk_oracle(a, b, rel))
        }
        _ => newton_oracle(a, b, rel),
    }
}

/// n³ bodies of the given shapes (species alternating by index), placed on
/// a dilute lattice with random orientations and compressed by MC to `phi`:
/// the starting state of the dynamics tests.
pub fn compressed_state(shapes: &[&str], n: usize, phi: f64, seed: u64) -> hardbody::state::System {
    compressed_state_tilted(shapes, n, phi, seed, V3::zeros())
}

/// [`compressed_state`] in a box with tilt factors `tilts`: the dilute
/// lattice is stretched by 1.6 and sheared into the tilted box (which
/// shortens no separation while the shear's smallest stretch is above
/// 1/1.6), then compressed.
#[allow(dead_code)]
pub fn compressed_state_tilted(
    shapes: &[&str],
    n: usize,
    phi: f64,
    seed: u64,
    tilts: V3,
) -> hardbody::state::System {
    use hardbody::mc::compress::{CompressOptions, compress};
    use hardbody::mc::moves::MoveSizes;
    use rand::SeedableRng;
    let mut rng = Pcg64::seed_from_u64(seed);
    let species = shapes
        .iter()
        .map(|s| hardbody::state::Species {
            name: s.to_string(),
            shape: s.parse::<Shape>().unwrap(),
            rotation: true,
        })
        .collect();
    let count = shapes.len();
    let mut system =
        hardbody::state::start::dilute_lattice(n, species, |i| (i % count) as u16, &mut rng)
            .unwrap();
    if tilts != V3::zeros() {
        let stretch = 1.6;
        let upright = system.periodic_box();
        let box_ =
            hardbody::space::PeriodicBox::triclinic(upright.lengths() * stretch, tilts).unwrap();
        let particles = system
            .particles()
            .iter()
            .map(|p| hardbody::state::Particle {
                position: box_.wrap(&box_.shear(&(p.position * stretch))),
                ..*p
            })
            .collect();
        system = hardbody::state::System::new(box_, system.species().to_vec(), particles).unwrap();
    }
    let sizes = MoveSizes {
        translate: 0.3,
        rotate: 0.3,
        volume: 0.0,
        shear: 0.01,
    };
    compress(&mut system, sizes, &CompressOptions::to(phi), &mut rng).unwrap();
    system
}

/// The `.ron` files in `dir` (relative to the crate's root), sorted.
pub fn scene_files(dir: &str) -> Vec<std::path::PathBuf> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(dir);
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(&root)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "ron"))
        .collect();
    files.sort();
    files
}

/// The shortest prefix of the log `bytes` that holds `k` frames (a cut
/// just after frame k, as a crash would leave it), by bisection on the
/// length.
pub fn cut_after_frames(bytes: &[u8], k: usize) -> usize {
    use hardbody::log::read::{ReadOptions, read_log_bytes};
    let frames_in = |len: usize| {
        let options = ReadOptions {
            all_states: true,
            messages: false,
        };
        read_log_bytes(&bytes[..len], std::path::Path::new("probe"), options)
            .map(|l| l.states.len())
            .unwrap_or(0)
    };
    let (mut lo, mut hi) = (0, bytes.len());
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if frames_in(mid) >= k {
            hi = mid
        } else {
            lo = mid
        }
    }
    hi
}

/// The averages of `wanted` (stage index, observable) over the replicas
/// whose scene texts `scene_of(replica)` gives (two), each run to a log
/// in a scratch folder named for `name`: mean, error, whether every
/// replica equilibrated.
#[allow(dead_code)]
pub fn replica_averages(
    name: &str,
    scene_of: impl Fn(u64) -> String,
    wanted: &[(usize, &str)],
) -> Vec<(f64, f64, bool)> {
    use hardbody::log::averages::{over_replicas, stage_averages};
    use hardbody::log::read::read_log;
    use hardbody::run::{Silent, run_scene};
    use hardbody::scene::Scene;
    let dir = std::env::temp_dir().join(format!("hardbody-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let runs: Vec<Vec<_>> = (0..2)
        .map(|replica| {
            let text = scene_of(replica);
            let log = dir.join(format!("{replica}-{:x}.mcap", fxhash(&text)));
            let scene = Scene::parse(&text).unwrap();
            run_scene(
                &scene,
                &text,
                &log,
                &mut Silent,
                &std::sync::atomic::AtomicBool::new(false),
            )
            .unwrap();
            let stats: Vec<_> = (read_log(&log, false).unwrap().stats.into_iter())
                .map(|(_, s)| s)
                .collect();
            let _ = std::fs::remove_file(&log);
            let averages = stage_averages(&stats);
            (wanted.iter())
                .map(|&(index, name)| {
                    let stage = averages.iter().find(|s| s.stage_index == index).unwrap();
                    stage.observables[name].estimate
                })
                .collect()
        })
        .collect();
    (0..wanted.len())
        .map(|k| {
            let a = over_replicas(&[runs[0][k], runs[1][k]]);
            (a.mean, a.error, a.equilibrated)
        })
        .collect()
}

/// A hash of a scene's text, to name its log apart from others run at
/// once.
#[allow(dead_code)]
fn fxhash(text: &str) -> u64 {
    text.bytes().fold(0xcbf2_9ce4_8422_2325, |h, b| {
        (h ^ u64::from(b)).wrapping_mul(0x100_0000_01b3)
    })
}
