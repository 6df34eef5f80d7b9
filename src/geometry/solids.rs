//! The named convex polyhedra: the five Platonic solids and the truncated
//! octahedron, each the hull of its corners, centred, of a given edge
//! length.

use nalgebra::Vector3;

type V3 = Vector3<f64>;

/// A named convex polyhedron.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Solid {
    /// The regular tetrahedron.
    Tetrahedron,
    /// The cube.
    Cube,
    /// The regular octahedron.
    Octahedron,
    /// The regular dodecahedron.
    Dodecahedron,
    /// The regular icosahedron.
    Icosahedron,
    /// The truncated octahedron (the Archimedean solid that tiles space).
    TruncatedOctahedron,
}

/// The golden ratio.
const PHI: f64 = 1.618_033_988_749_895;

impl Solid {
    /// Every solid, in the order above.
    pub const ALL: [Solid; 6] = [
        Solid::Tetrahedron,
        Solid::Cube,
        Solid::Octahedron,
        Solid::Dodecahedron,
        Solid::Icosahedron,
        Solid::TruncatedOctahedron,
    ];

    /// The corners of the solid of edge length `edge`, centred on the
    /// origin: the textbook coordinates (the tetrahedron the even corners
    /// of the cube (±1, ±1, ±1), the octahedron the unit axes, the
    /// icosahedron the cyclic permutations of (0, ±1, ±φ), the dodecahedron
    /// the cube's corners and those of (0, ±1/φ, ±φ), the truncated
    /// octahedron the permutations of (0, ±1, ±2)) scaled from their edge.
    pub fn corners(&self, edge: f64) -> Vec<V3> {
        let signs = |v: [f64; 3]| -> Vec<V3> {
            let mut out = Vec::new();
            for k in 0..8 {
                let s = [0, 1, 2].map(|a| if k >> a & 1 == 1 { -1.0 } else { 1.0 });
                let p = V3::new(v[0] * s[0], v[1] * s[1], v[2] * s[2]);
                if !out.contains(&p) {
                    out.push(p);
                }
            }
            out
        };
        let cyclic = |v: [f64; 3]| -> Vec<V3> {
            [[0, 1, 2], [1, 2, 0], [2, 0, 1]]
                .iter()
                .flat_map(|o| signs([v[o[0]], v[o[1]], v[o[2]]]))
                .collect()
        };
        let (points, unit_edge): (Vec<V3>, f64) = match self {
            Solid::Tetrahedron => (
                signs([1.0, 1.0, 1.0])
                    .into_iter()
                    .filter(|p| p.x * p.y * p.z > 0.0)
                    .collect(),
                8f64.sqrt(),
            ),
            Solid::Cube => (signs([1.0, 1.0, 1.0]), 2.0),
            Solid::Octahedron => (cyclic([1.0, 0.0, 0.0]), 2f64.sqrt()),
            Solid::Icosahedron => (cyclic([0.0, 1.0, PHI]), 2.0),
            Solid::Dodecahedron => {
                let mut p = signs([1.0, 1.0, 1.0]);
                p.extend(cyclic([0.0, 1.0 / PHI, PHI]));
                (p, 2.0 / PHI)
            }
            Solid::TruncatedOctahedron => {
                let perms = [
                    [0, 1, 2],
                    [0, 2, 1],
                    [1, 0, 2],
                    [1, 2, 0],
                    [2, 0, 1],
                    [2, 1, 0],
                ];
                let v = [0.0, 1.0, 2.0];
                (
                    perms
                        .iter()
                        .flat_map(|o| signs([v[o[0]], v[o[1]], v[o[2]]]))
                        .collect(),
                    2f64.sqrt(),
                )
            }
        };
        points.into_iter().map(|p| p * (edge / unit_edge)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::polyhedron::ConvexPolyhedron;

    /// Each solid of edge 1.3: its corners, edges and faces counted, its
    /// edges all of that length, and its volume the closed form
    /// (tetrahedron a³/(6√2), cube a³, octahedron √2a³/3, dodecahedron
    /// (15 + 7√5)a³/4, icosahedron 5(3 + √5)a³/12, truncated octahedron
    /// 8√2a³); its inertia isotropic (cubic or icosahedral symmetry), the
    /// cube's a²/6.
    #[test]
    fn the_solids_have_their_counts_edges_and_volumes() {
        let a = 1.3f64;
        let r5 = 5f64.sqrt();
        let expected = [
            ((4, 6, 4), a.powi(3) / (6.0 * 2f64.sqrt())),
            ((8, 12, 6), a.powi(3)),
            ((6, 12, 8), 2f64.sqrt() * a.powi(3) / 3.0),
            ((20, 30, 12), (15.0 + 7.0 * r5) * a.powi(3) / 4.0),
            ((12, 30, 20), 5.0 * (3.0 + r5) * a.powi(3) / 12.0),
            ((24, 36, 14), 8.0 * 2f64.sqrt() * a.powi(3)),
        ];
        for (solid, (counts, volume)) in Solid::ALL.into_iter().zip(expected) {
            let p = ConvexPolyhedron::solid(solid, a).unwrap();
            let h = p.hull();
            assert_eq!(
                (h.vertices().len(), h.edges().len(), h.faces().len()),
                counts,
                "{solid:?}"
            );
            for &(i, j) in h.edges() {
                let l = (h.vertices()[i] - h.vertices()[j]).norm();
                assert!((l - a).abs() < 1e-12, "{solid:?}: edge {l}");
            }
            assert!((h.volume() - volume).abs() < 1e-12 * volume, "{solid:?}");
            let i = h.inertia();
            assert!(
                (i - nalgebra::Matrix3::identity() * i[(0, 0)]).norm() < 1e-12,
                "{solid:?}: {i}"
            );
            assert_eq!(h.named(), Some((solid, a)));
        }
        let cube = ConvexPolyhedron::solid(Solid::Cube, a).unwrap();
        assert!((cube.hull().inertia()[(1, 1)] - a * a / 6.0).abs() < 1e-12);
        assert!(ConvexPolyhedron::solid(Solid::Cube, 0.0).is_err());
    }
}
