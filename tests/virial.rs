//! Excluded volumes from Monte Carlo (`hardbody virial`) against the exact
//! Isihara–Hadwiger result for convex bodies:
//! V_excl = V_A + V_B + (M_A S_B + M_B S_A) / 4π,
//! S the surface area and M the integrated mean curvature (= ∫ h(u) dΩ, the
//! support function integrated over directions). S and M are computed here
//! independently of the library: closed forms for spheres and boxes,
//! quadrature over the surface of revolution for spheroids.

use std::f64::consts::PI;
use std::process::Command;

use hardbody::analysis::virial::excluded_volume;
use hardbody::geometry::Shape;

/// Volume, surface area and integrated mean curvature of a convex body.
struct Minkowski {
    v: f64,
    s: f64,
    m: f64,
}

fn sphere(r: f64) -> Minkowski {
    Minkowski {
        v: 4.0 / 3.0 * PI * r.powi(3),
        s: 4.0 * PI * r * r,
        m: 4.0 * PI * r,
    }
}

/// Box with half-lengths a, b, c (edges 2a, 2b, 2c): M = ½ Σ_edges L (π − θ)
/// = π (2a + 2b + 2c).
fn cuboid(a: f64, b: f64, c: f64) -> Minkowski {
    let (x, y, z) = (2.0 * a, 2.0 * b, 2.0 * c);
    Minkowski {
        v: x * y * z,
        s: 2.0 * (x * y + y * z + x * z),
        m: PI * (x + y + z),
    }
}

/// Spheroid with semi-axis `c` along the symmetry axis and `a` across:
/// S = 2π ∫₀^π a sinθ √(a² cos²θ + c² sin²θ) dθ,
/// M = 2π ∫₀^π √(c² cos²θ + a² sin²θ) sinθ dθ, by composite Simpson.
fn spheroid(a: f64, c: f64) -> Minkowski {
    let simpson = |f: &dyn Fn(f64) -> f64| {
        let n = 20_000;
        let h = PI / n as f64;
        let mut sum = f(0.0) + f(PI);
        for k in 1..n {
            sum += f(k as f64 * h) * if k % 2 == 1 { 4.0 } else { 2.0 };
        }
        sum * h / 3.0
    };
    let s = 2.0
        * PI
        * simpson(&|t: f64| {
            a * t.sin() * (a * a * t.cos().powi(2) + c * c * t.sin().powi(2)).sqrt()
        });
    let m = 2.0
        * PI
        * simpson(&|t: f64| (c * c * t.cos().powi(2) + a * a * t.sin().powi(2)).sqrt() * t.sin());
    Minkowski {
        v: 4.0 / 3.0 * PI * a * a * c,
        s,
        m,
    }
}

/// Spherocylinder of radius `r` and cylinder length `l`: the segment of
/// length l (M = πl, no volume or area) swept by the ball of radius r
/// (Steiner: S = 2πrl + 4πr², M = πl + 4πr).
fn spherocylinder(r: f64, l: f64) -> Minkowski {
    Minkowski {
        v: PI * r * r * l + 4.0 / 3.0 * PI * r.powi(3),
        s: 2.0 * PI * r * l + 4.0 * PI * r * r,
        m: PI * l + 4.0 * PI * r,
    }
}

fn isihara_hadwiger(x: &Minkowski, y: &Minkowski) -> f64 {
    x.v + y.v + (x.m * y.s + y.m * x.s) / (4.0 * PI)
}

fn check(a: &str, b: &str, exact: f64, seed: u64) {
    let (sa, sb): (Shape, Shape) = (a.parse().unwrap(), b.parse().unwrap());
    let e = excluded_volume(&sa, &sb, 2_000_000, seed);
    if e.excluded_volume_error == 0.0 {
        // Every sample overlapped (two spheres: the sampling ball is the
        // excluded volume): the estimate must then be exact.
        assert!(
            (e.excluded_volume - exact).abs() < 1e-12 * exact,
            "{a} / {b}: {} vs {exact}",
            e.excluded_volume
        );
    } else {
        let z = (e.excluded_volume - exact) / e.excluded_volume_error;
        assert!(
            z.abs() < 3.0,
            "{a} / {b}: MC {} ± {}, exact {exact} ({z:.2} σ)",
            e.excluded_volume,
            e.excluded_volume_error
        );
        // The error is a real uncertainty, not a token: 2×10⁶ samples give
        // about 0.1 % here.
        assert!(e.excluded_volume_error < 0.01 * exact && e.excluded_volume_error > 1e-5 * exact);
    }
    assert!((e.b2 - e.excluded_volume / 2.0).abs() < 1e-12);
}

#[test]
fn quadrature_reproduces_the_sphere() {
    let s = spheroid(0.7, 0.7);
    assert!((s.s - 4.0 * PI * 0.49).abs() < 1e-9 && (s.m - 4.0 * PI * 0.7).abs() < 1e-9);
}

#[test]
fn sphere_sphere() {
    check(
        "Sphere(radius: 0.5)",
        "Sphere(radius: 0.5)",
        isihara_hadwiger(&sphere(0.5), &sphere(0.5)),
        1,
    );
    // Unequal radii: (4/3)π (R₁ + R₂)³.
    let exact = 4.0 / 3.0 * PI;
    assert!((isihara_hadwiger(&sphere(0.3), &sphere(0.7)) - exact).abs() < 1e-12);
    check("Sphere(radius: 0.3)", "Sphere(radius: 0.7)", exact, 2);
}

#[test]
fn cube_cube() {
    let c = cuboid(0.5, 0.5, 0.5);
    // Unit cubes: V_excl = 2 + 6·3π/(4π)·2 ... = 2 + 9 = 11.
    assert!((isihara_hadwiger(&c, &c) - 11.0).abs() < 1e-12);
    check(
        "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
        "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
        11.0,
        3,
    );
}

#[test]
fn cuboid_sphere() {
    let exact = isihara_hadwiger(&cuboid(0.5, 1.0, 1.5), &sphere(0.5));
    check(
        "Cuboid(a: 0.5, b: 1.0, c: 1.5)",
        "Sphere(radius: 0.5)",
        exact,
        4,
    );
}

#[test]
fn spheroid_spheroid() {
    // Prolate (aspect 2), oblate (aspect 0.5), and one of each.
    let prolate = spheroid(0.5, 1.0);
    let oblate = spheroid(1.0, 0.5);
    check(
        "Ellipsoid(a: 0.5, b: 0.5, c: 1.0)",
        "Ellipsoid(a: 0.5, b: 0.5, c: 1.0)",
        isihara_hadwiger(&prolate, &prolate),
        5,
    );
    check(
        "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
        "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
        isihara_hadwiger(&oblate, &oblate),
        6,
    );
    check(
        "Ellipsoid(a: 0.5, b: 0.5, c: 1.0)",
        "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
        isihara_hadwiger(&prolate, &oblate),
        7,
    );
}

/// Spherocylinders with each other (Onsager's closed form for two equal
/// ones, 32πr³/3 + 8πlr² + πl²r, checked against Isihara–Hadwiger first),
/// with spheres, cuboids and spheroids: the closed-form segment test and
/// GJK alike.
#[test]
fn spherocylinder_pairs() {
    let (r, l) = (0.5, 2.0);
    let rod = spherocylinder(r, l);
    let onsager = 32.0 * PI * r.powi(3) / 3.0 + 8.0 * PI * l * r * r + PI * l * l * r;
    assert!((isihara_hadwiger(&rod, &rod) - onsager).abs() < 1e-12 * onsager);
    let text = "Spherocylinder(radius: 0.5, length: 2.0)";
    check(text, text, onsager, 11);
    let short = "Spherocylinder(radius: 0.3, length: 0.4)";
    check(
        text,
        short,
        isihara_hadwiger(&rod, &spherocylinder(0.3, 0.4)),
        12,
    );
    check(
        text,
        "Sphere(radius: 0.7)",
        isihara_hadwiger(&rod, &sphere(0.7)),
        13,
    );
    check(
        text,
        "Cuboid(a: 0.5, b: 0.4, c: 0.3)",
        isihara_hadwiger(&rod, &cuboid(0.5, 0.4, 0.3)),
        14,
    );
    check(
        "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
        text,
        isihara_hadwiger(&spheroid(1.0, 0.5), &rod),
        15,
    );
}

/// Regular tetrahedron of edge `a`: V = a³/(6√2), S = √3 a², and M =
/// ½ Σ_edges L (π − θ) with the dihedral angle θ = arccos(1/3).
fn tetrahedron(a: f64) -> Minkowski {
    Minkowski {
        v: a.powi(3) / (6.0 * 2f64.sqrt()),
        s: 3f64.sqrt() * a * a,
        m: 0.5 * 6.0 * a * (PI - (1.0f64 / 3.0).acos()),
    }
}

/// Regular octahedron of edge `a`: V = √2 a³/3, S = 2√3 a², dihedral
/// angle arccos(−1/3) at each of 12 edges.
fn octahedron(a: f64) -> Minkowski {
    Minkowski {
        v: 2f64.sqrt() * a.powi(3) / 3.0,
        s: 2.0 * 3f64.sqrt() * a * a,
        m: 0.5 * 12.0 * a * (PI - (-1.0f64 / 3.0).acos()),
    }
}

/// Convex polyhedra (GJK on their corners) with each other and with
/// every other shape: a tetrahedron of edge 2√2 (alternate corners of the
/// cube of side 2), an octahedron of edge √2 (the unit axes), and a
/// cube given by its corners against the cuboid's own result.
#[test]
fn polyhedron_pairs() {
    let tetra = "ConvexPolyhedron(vertices: [(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), \
                 (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0)])";
    let octa = "ConvexPolyhedron(vertices: [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), \
                (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)])";
    let cube = "ConvexPolyhedron(vertices: [(0.5, 0.5, 0.5), (0.5, 0.5, -0.5), (0.5, -0.5, 0.5), \
                (0.5, -0.5, -0.5), (-0.5, 0.5, 0.5), (-0.5, 0.5, -0.5), (-0.5, -0.5, 0.5), \
                (-0.5, -0.5, -0.5)])";
    let (t, o) = (tetrahedron(8f64.sqrt()), octahedron(2f64.sqrt()));
    check(tetra, tetra, isihara_hadwiger(&t, &t), 21);
    check(octa, octa, isihara_hadwiger(&o, &o), 22);
    check(tetra, octa, isihara_hadwiger(&t, &o), 23);
    check(
        tetra,
        "Sphere(radius: 0.6)",
        isihara_hadwiger(&t, &sphere(0.6)),
        24,
    );
    check(
        octa,
        "Spherocylinder(radius: 0.3, length: 1.0)",
        isihara_hadwiger(&o, &spherocylinder(0.3, 1.0)),
        25,
    );
    check(
        "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
        tetra,
        isihara_hadwiger(&spheroid(1.0, 0.5), &t),
        26,
    );
    check(
        cube,
        "Cuboid(a: 0.5, b: 0.4, c: 0.3)",
        isihara_hadwiger(&cuboid(0.5, 0.5, 0.5), &cuboid(0.5, 0.4, 0.3)),
        27,
    );
}

/// A body swept by a ball of radius r (Steiner: V + S r + M r² + 4πr³/3,
/// S + 2 M r + 4πr², M + 4πr).
fn swept(x: &Minkowski, r: f64) -> Minkowski {
    Minkowski {
        v: x.v + x.s * r + x.m * r * r + 4.0 / 3.0 * PI * r.powi(3),
        s: x.s + 2.0 * x.m * r + 4.0 * PI * r * r,
        m: x.m + 4.0 * PI * r,
    }
}

/// Spheropolyhedra (GJK between the cores against the rounding) with each
/// other and with every other shape: a rounded tetrahedron, a rounded
/// cube and a rounded octahedron.
#[test]
fn spheropolyhedron_pairs() {
    let tetra = "Spheropolyhedron(vertices: [(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), \
                 (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0)], radius: 0.25)";
    let cube = "Spheropolyhedron(vertices: [(0.5, 0.5, 0.5), (0.5, 0.5, -0.5), (0.5, -0.5, 0.5), \
                (0.5, -0.5, -0.5), (-0.5, 0.5, 0.5), (-0.5, 0.5, -0.5), (-0.5, -0.5, 0.5), \
                (-0.5, -0.5, -0.5)], radius: 0.1)";
    let octa = "Spheropolyhedron(vertices: [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), \
                (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)], radius: 0.4)";
    let t = swept(&tetrahedron(8f64.sqrt()), 0.25);
    let c = swept(&cuboid(0.5, 0.5, 0.5), 0.1);
    let o = swept(&octahedron(2f64.sqrt()), 0.4);
    check(tetra, tetra, isihara_hadwiger(&t, &t), 31);
    check(cube, cube, isihara_hadwiger(&c, &c), 32);
    check(tetra, octa, isihara_hadwiger(&t, &o), 33);
    check(
        cube,
        "Sphere(radius: 0.6)",
        isihara_hadwiger(&c, &sphere(0.6)),
        34,
    );
    check(
        octa,
        "Spherocylinder(radius: 0.3, length: 1.0)",
        isihara_hadwiger(&o, &spherocylinder(0.3, 1.0)),
        35,
    );
    check(
        "Ellipsoid(a: 1.0, b: 1.0, c: 0.5)",
        tetra,
        isihara_hadwiger(&spheroid(1.0, 0.5), &t),
        36,
    );
    check(
        cube,
        "Cuboid(a: 0.5, b: 0.4, c: 0.3)",
        isihara_hadwiger(&c, &cuboid(0.5, 0.4, 0.3)),
        37,
    );
    check(
        "ConvexPolyhedron(vertices: [(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), \
         (-1.0, -1.0, 1.0)])",
        cube,
        isihara_hadwiger(&tetrahedron(8f64.sqrt()), &c),
        38,
    );
}

/// The command line end to end: JSON with the documented keys, and a clear
/// error for a bad shape.
#[test]
fn virial_command() {
    let out = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args([
            "virial",
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
        ])
        .args(["--samples", "400000", "--seed", "9", "--json"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let (ev, err) = (
        v["excluded_volume"].as_f64().unwrap(),
        v["excluded_volume_error"].as_f64().unwrap(),
    );
    assert!(((ev - 11.0) / err).abs() < 3.0, "{ev} ± {err}");
    assert_eq!(v["samples"].as_u64(), Some(400_000));
    assert!((v["b2"].as_f64().unwrap() - ev / 2.0).abs() < 1e-12);

    let bad = Command::new(env!("CARGO_BIN_EXE_hardbody"))
        .args([
            "virial",
            "Cuboid(a: -0.5, b: 0.5, c: 0.5)",
            "Sphere(radius: 1.0)",
        ])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let msg = String::from_utf8_lossy(&bad.stderr);
    assert!(msg.contains("Cuboid") && msg.contains('a'), "{msg}");
}
