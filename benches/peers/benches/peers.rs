//! hardbody's overlap kernels against hoomd-geometry 1.4 (the Glotzer lab's
//! Rust HPMC geometry) and parry3d-f64 on the same placements, measured side
//! by side in one run. Run with `cargo bench` from `benches/peers/`.
//!
//! Placements: random orientations, centre distances uniform in
//! [0.5, 1.0] × the sum of bounding radii (about half overlapping).

use std::hint::black_box;

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use hardbody::analysis::virial::random_rotation;
use hardbody::geometry::{Relative, Shape, overlap};
use hoomd_geometry::shape::{Hypercuboid, Hyperellipsoid, Sphere as HSphere};
use hoomd_geometry::{Convex, IntersectsAt};
use hoomd_vector::{Cartesian, Quaternion, Versor};
use nalgebra::{UnitQuaternion, Vector3};
use parry3d_f64::math::{Pose, Vector};
use parry3d_f64::query::intersection_test;
use parry3d_f64::shape::{Ball, Cuboid as PCuboid};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

/// B relative to A: centre in A's frame and orientation q_A⁻¹ q_B.
struct Placement {
    r: Vector3<f64>,
    q: UnitQuaternion<f64>,
}

fn placements(reach: f64) -> Vec<Placement> {
    let mut rng = Pcg64::seed_from_u64(11);
    (0..1024)
        .map(|_| {
            let q = random_rotation(&mut rng);
            let dir = random_rotation(&mut rng) * Vector3::x();
            Placement {
                r: dir * reach * (0.5 + 0.5 * rng.r#gen::<f64>()),
                q,
            }
        })
        .collect()
}

fn ours(a: &Shape, b: &Shape, ps: &[Placement]) -> Vec<Relative> {
    let _ = (a, b);
    ps.iter()
        .map(|p| Relative {
            translation: p.r,
            rotation: p.q.to_rotation_matrix().into_inner(),
        })
        .collect()
}

fn versor(q: &UnitQuaternion<f64>) -> Versor {
    Quaternion::from([q.w, q.i, q.j, q.k]).to_versor_unchecked()
}

fn cart(v: &Vector3<f64>) -> Cartesian<3> {
    Cartesian::from([v.x, v.y, v.z])
}

fn parry_pose(p: &Placement) -> Pose {
    let rot = parry3d_f64::math::Rotation::from_xyzw(p.q.i, p.q.j, p.q.k, p.q.w);
    Pose::from_parts(Vector::new(p.r.x, p.r.y, p.r.z), rot)
}

fn pos(x: f64) -> hoomd_utility::valid::PositiveReal {
    x.try_into().unwrap()
}

fn bench(c: &mut Criterion) {
    let mut group = c.benchmark_group("peers");
    group.throughput(Throughput::Elements(1024));

    // Agreement first: the peers must answer as we do on these placements
    // (up to their own tolerances), or the timing compares different work.
    let check = |name: &str, ours: &[bool], theirs: &[bool]| {
        let differ = ours.iter().zip(theirs).filter(|(a, b)| a != b).count();
        eprintln!("{name}: {differ} of {} answers differ", ours.len());
    };

    // Sphere–sphere.
    {
        let s: Shape = "Sphere(radius: 0.5)".parse().unwrap();
        let ps = placements(1.0);
        let rel = ours(&s, &s, &ps);
        let h = HSphere { radius: pos(0.5) };
        let vs: Vec<(Cartesian<3>, Versor)> =
            ps.iter().map(|p| (cart(&p.r), versor(&p.q))).collect();
        let ball = Ball::new(0.5);
        let poses: Vec<Pose> = ps.iter().map(parry_pose).collect();
        check(
            "sphere_sphere hoomd",
            &rel.iter().map(|r| overlap(&s, &s, r)).collect::<Vec<_>>(),
            &vs.iter()
                .map(|(v, q)| h.intersects_at(&h, v, q))
                .collect::<Vec<_>>(),
        );
        group.bench_function("sphere_sphere/hardbody", |b| {
            b.iter(|| rel.iter().filter(|r| overlap(&s, &s, black_box(r))).count())
        });
        group.bench_function("sphere_sphere/hoomd", |b| {
            b.iter(|| {
                vs.iter()
                    .filter(|(v, q)| h.intersects_at(&h, black_box(v), q))
                    .count()
            })
        });
        group.bench_function("sphere_sphere/parry", |b| {
            b.iter(|| {
                poses
                    .iter()
                    .filter(|p| {
                        intersection_test(&Pose::IDENTITY, &ball, black_box(p), &ball).unwrap()
                    })
                    .count()
            })
        });
    }

    // Cuboid–sphere.
    {
        let (cb, sp): (Shape, Shape) = (
            "Cuboid(a: 0.5, b: 1.0, c: 1.5)".parse().unwrap(),
            "Sphere(radius: 0.5)".parse().unwrap(),
        );
        let ps = placements(cb.bounding_radius() + 0.5);
        let rel = ours(&cb, &sp, &ps);
        let hc = Convex(Hypercuboid {
            edge_lengths: [pos(1.0), pos(2.0), pos(3.0)],
        });
        let hs = Convex(HSphere { radius: pos(0.5) });
        let vs: Vec<(Cartesian<3>, Versor)> =
            ps.iter().map(|p| (cart(&p.r), versor(&p.q))).collect();
        let pc = PCuboid::new(Vector::new(0.5, 1.0, 1.5));
        let ball = Ball::new(0.5);
        let poses: Vec<Pose> = ps.iter().map(parry_pose).collect();
        let mine: Vec<bool> = rel.iter().map(|r| overlap(&cb, &sp, r)).collect();
        check(
            "cuboid_sphere hoomd",
            &mine,
            &vs.iter()
                .map(|(v, q)| hc.intersects_at(&hs, v, q))
                .collect::<Vec<_>>(),
        );
        check(
            "cuboid_sphere parry",
            &mine,
            &poses
                .iter()
                .map(|p| intersection_test(&Pose::IDENTITY, &pc, p, &ball).unwrap())
                .collect::<Vec<_>>(),
        );
        group.bench_function("cuboid_sphere/hardbody", |b| {
            b.iter(|| {
                rel.iter()
                    .filter(|r| overlap(&cb, &sp, black_box(r)))
                    .count()
            })
        });
        group.bench_function("cuboid_sphere/hoomd", |b| {
            b.iter(|| {
                vs.iter()
                    .filter(|(v, q)| hc.intersects_at(&hs, black_box(v), q))
                    .count()
            })
        });
        group.bench_function("cuboid_sphere/parry", |b| {
            b.iter(|| {
                poses
                    .iter()
                    .filter(|p| {
                        intersection_test(&Pose::IDENTITY, &pc, black_box(p), &ball).unwrap()
                    })
                    .count()
            })
        });
    }

    // Cuboid–cuboid.
    {
        let cb: Shape = "Cuboid(a: 0.5, b: 1.0, c: 1.5)".parse().unwrap();
        let ps = placements(2.0 * cb.bounding_radius());
        let rel = ours(&cb, &cb, &ps);
        let hc = Convex(Hypercuboid {
            edge_lengths: [pos(1.0), pos(2.0), pos(3.0)],
        });
        let vs: Vec<(Cartesian<3>, Versor)> =
            ps.iter().map(|p| (cart(&p.r), versor(&p.q))).collect();
        let pc = PCuboid::new(Vector::new(0.5, 1.0, 1.5));
        let poses: Vec<Pose> = ps.iter().map(parry_pose).collect();
        let mine: Vec<bool> = rel.iter().map(|r| overlap(&cb, &cb, r)).collect();
        check(
            "cuboid_cuboid hoomd",
            &mine,
            &vs.iter()
                .map(|(v, q)| hc.intersects_at(&hc, v, q))
                .collect::<Vec<_>>(),
        );
        check(
            "cuboid_cuboid parry",
            &mine,
            &poses
                .iter()
                .map(|p| intersection_test(&Pose::IDENTITY, &pc, p, &pc).unwrap())
                .collect::<Vec<_>>(),
        );
        group.bench_function("cuboid_cuboid/hardbody", |b| {
            b.iter(|| {
                rel.iter()
                    .filter(|r| overlap(&cb, &cb, black_box(r)))
                    .count()
            })
        });
        group.bench_function("cuboid_cuboid/hoomd", |b| {
            b.iter(|| {
                vs.iter()
                    .filter(|(v, q)| hc.intersects_at(&hc, black_box(v), q))
                    .count()
            })
        });
        group.bench_function("cuboid_cuboid/parry", |b| {
            b.iter(|| {
                poses
                    .iter()
                    .filter(|p| intersection_test(&Pose::IDENTITY, &pc, black_box(p), &pc).unwrap())
                    .count()
            })
        });
    }

    // Ellipsoid–ellipsoid, sphere–ellipsoid, cuboid–ellipsoid (hoomd only:
    // parry has no ellipsoid).
    {
        let el: Shape = "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)".parse().unwrap();
        let sp: Shape = "Sphere(radius: 0.5)".parse().unwrap();
        let cb: Shape = "Cuboid(a: 0.5, b: 1.0, c: 1.5)".parse().unwrap();
        let he = Convex(Hyperellipsoid::<3>::with_semi_axes([
            pos(1.0),
            pos(0.5),
            pos(0.5),
        ]));
        let hs = Convex(HSphere { radius: pos(0.5) });
        let hc = Convex(Hypercuboid {
            edge_lengths: [pos(1.0), pos(2.0), pos(3.0)],
        });
        for (name, a, b) in [
            ("ellipsoid_ellipsoid", &el, &el),
            ("sphere_ellipsoid", &sp, &el),
            ("cuboid_ellipsoid", &cb, &el),
        ] {
            let ps = placements(a.bounding_radius() + b.bounding_radius());
            let rel = ours(a, b, &ps);
            let vs: Vec<(Cartesian<3>, Versor)> =
                ps.iter().map(|p| (cart(&p.r), versor(&p.q))).collect();
            let theirs = |v: &Cartesian<3>, q: &Versor| match name {
                "ellipsoid_ellipsoid" => he.intersects_at(&he, v, q),
                "sphere_ellipsoid" => hs.intersects_at(&he, v, q),
                _ => hc.intersects_at(&he, v, q),
            };
            check(
                &format!("{name} hoomd"),
                &rel.iter().map(|r| overlap(a, b, r)).collect::<Vec<_>>(),
                &vs.iter().map(|(v, q)| theirs(v, q)).collect::<Vec<_>>(),
            );
            group.bench_function(format!("{name}/hardbody"), |bch| {
                bch.iter(|| rel.iter().filter(|r| overlap(a, b, black_box(r))).count())
            });
            group.bench_function(format!("{name}/hoomd"), |bch| {
                bch.iter(|| vs.iter().filter(|(v, q)| theirs(black_box(v), q)).count())
            });
        }
    }
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
