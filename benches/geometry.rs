//! Criterion benchmarks of the geometry kernels: per-call times of the
//! overlap tests and distances, OCSI batched in cache.

use std::hint::black_box;

use criterion::{BatchSize, Criterion, Throughput, criterion_group, criterion_main};
use hardbody::analysis::virial::random_rotation;
use hardbody::bench::ocsi::sampling_radius;
use hardbody::geometry::ocsi::{Spheres, ocsi, ocsi_batch, point_box_distance, qrf, qri};
use hardbody::geometry::{DistanceOptions, Relative, Shape, distance, overlap};
use nalgebra::{Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

fn ocsi_kernels(c: &mut Criterion) {
    let mut rng = Pcg64::seed_from_u64(1);
    let n = 1024;
    let half = Vector3::new(0.5, 5.0, 2.5);
    let axes = random_rotation(&mut rng).to_rotation_matrix().into_inner();
    // Centres uniform in the spherocuboid with 40% non-overlapping (the
    // protocol of Tonti & Patti, as `hardbody bench ocsi`).
    let dilation = sampling_radius(&(half * 2.0), 0.5, 0.4);
    let reach = half.add_scalar(dilation);
    let (mut xs, mut ys, mut zs) = (Vec::new(), Vec::new(), Vec::new());
    while xs.len() < n {
        let p = Vector3::new(
            reach.x * (2.0 * rng.r#gen::<f64>() - 1.0),
            reach.y * (2.0 * rng.r#gen::<f64>() - 1.0),
            reach.z * (2.0 * rng.r#gen::<f64>() - 1.0),
        );
        if point_box_distance(&p, &half).0 <= dilation {
            let q = axes * p;
            xs.push(q.x);
            ys.push(q.y);
            zs.push(q.z);
        }
    }
    let radii = vec![0.5; n];
    let mut out = vec![false; n];
    let mut group = c.benchmark_group("ocsi");
    group.throughput(Throughput::Elements(n as u64));
    group.bench_function("batch_1024_spheres", |b| {
        b.iter(|| {
            let s = Spheres {
                x: &xs,
                y: &ys,
                z: &zs,
                radius: &radii,
            };
            ocsi_batch(
                &Vector3::zeros(),
                black_box(&axes),
                &half,
                black_box(&s),
                &mut out,
            );
            black_box(&out);
        })
    });
    let points: Vec<Vector3<f64>> = (0..n).map(|i| Vector3::new(xs[i], ys[i], zs[i])).collect();
    type Kernel = fn(&Vector3<f64>, f64, &Matrix3<f64>, &Vector3<f64>) -> bool;
    for (name, f) in [
        ("scalar_ocsi_1024", ocsi as Kernel),
        ("scalar_qrf_1024", qrf),
        ("scalar_qri_1024", qri),
    ] {
        group.bench_function(name, |b| {
            b.iter(|| {
                let mut hits = 0;
                for p in &points {
                    hits += f(black_box(p), 0.5, &axes, &half) as usize;
                }
                black_box(hits)
            })
        });
    }
    group.finish();
}

/// Near-contact placements (50% overlapping) of one pair.
fn placements(a: &Shape, b: &Shape, seed: u64) -> Vec<Relative> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..256)
        .map(|_| {
            let qa = random_rotation(&mut rng);
            let qb = random_rotation(&mut rng);
            let dir = random_rotation(&mut rng) * Vector3::x();
            let reach = a.bounding_radius() + b.bounding_radius();
            let r = dir * reach * (0.5 + 0.5 * rng.r#gen::<f64>());
            Relative::new(&r, &qa, &qb)
        })
        .collect()
}

fn pair_kernels(c: &mut Criterion) {
    let shapes: [(&str, &str, &str); 8] = [
        (
            "sphere_sphere",
            "Sphere(radius: 0.5)",
            "Sphere(radius: 0.5)",
        ),
        (
            "cuboid_sphere",
            "Cuboid(a: 0.5, b: 1.0, c: 1.5)",
            "Sphere(radius: 0.5)",
        ),
        (
            "cuboid_cuboid",
            "Cuboid(a: 0.5, b: 1.0, c: 1.5)",
            "Cuboid(a: 0.5, b: 1.0, c: 1.5)",
        ),
        (
            "ellipsoid_ellipsoid",
            "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)",
            "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)",
        ),
        (
            "sphere_ellipsoid",
            "Sphere(radius: 0.5)",
            "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)",
        ),
        (
            "superellipsoid_superellipsoid",
            "Superellipsoid(a: 1.0, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
            "Superellipsoid(a: 1.0, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
        ),
        (
            "cuboid_ellipsoid",
            "Cuboid(a: 0.5, b: 1.0, c: 1.5)",
            "Ellipsoid(a: 1.0, b: 0.5, c: 0.5)",
        ),
        (
            "cuboid_superellipsoid",
            "Cuboid(a: 0.5, b: 1.0, c: 1.5)",
            "Superellipsoid(a: 1.0, b: 0.5, c: 0.5, exponents: (4.0, 4.0, 4.0))",
        ),
    ];
    let mut group = c.benchmark_group("overlap");
    for (name, a, b) in shapes {
        let (a, b): (Shape, Shape) = (a.parse().unwrap(), b.parse().unwrap());
        let rels = placements(&a, &b, 3);
        group.throughput(Throughput::Elements(rels.len() as u64));
        group.bench_function(name, |bench| {
            bench.iter(|| {
                rels.iter()
                    .filter(|r| overlap(&a, &b, black_box(r)))
                    .count()
            })
        });
    }
    group.finish();

    // Newton distance, cold and warm started (the warm start is the solution
    // of the same pair after a small move, as in EDMD).
    let mut group = c.benchmark_group("distance");
    let opts = DistanceOptions::default();
    for (name, a, b) in &shapes[3..6] {
        let (a, b): (Shape, Shape) = (a.parse().unwrap(), b.parse().unwrap());
        let rels: Vec<Relative> = placements(&a, &b, 5)
            .into_iter()
            .map(|mut r| {
                r.translation *= 1.4; // apart: the distance is defined
                r
            })
            .collect();
        group.throughput(Throughput::Elements(rels.len() as u64));
        group.bench_function(format!("{name}_cold"), |bench| {
            bench.iter(|| {
                rels.iter()
                    .map(|r| distance(&a, &b, black_box(r), &opts, None).distance)
                    .sum::<f64>()
            })
        });
        let warm: Vec<_> = rels
            .iter()
            .map(|r| distance(&a, &b, r, &opts, None).warm_start)
            .collect();
        let moved: Vec<Relative> = rels
            .iter()
            .map(|r| Relative {
                translation: r.translation * 0.999,
                rotation: r.rotation,
            })
            .collect();
        group.bench_function(format!("{name}_warm"), |bench| {
            bench.iter_batched(
                || (),
                |_| {
                    moved
                        .iter()
                        .zip(&warm)
                        .map(|(r, w)| distance(&a, &b, black_box(r), &opts, w.as_ref()).distance)
                        .sum::<f64>()
                },
                BatchSize::SmallInput,
            )
        });
    }
    group.finish();
}

criterion_group!(benches, ocsi_kernels, pair_kernels);
criterion_main!(benches);
