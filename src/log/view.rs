//! `/scene`: the state drawn for Foxglove's 3D panel as one
//! `foxglove.SceneUpdate` per frame. All particles are one entity
//! (`particles`), so the panel instances them; the box is another (`box`,
//! twelve edges). Spheres and ellipsoids are sphere primitives with
//! per-axis size, cuboids cube primitives, superellipsoids triangle lists
//! (one body-frame mesh per species, placed by each particle's pose).
//! Colours are per species.

use foxglove::messages::{
    Color, CubePrimitive, LinePrimitive, Point3, Pose, Quaternion, SceneEntity, SceneUpdate,
    SpherePrimitive, Timestamp, TriangleListPrimitive, Vector3 as FVector3, line_primitive,
};
use nalgebra::Vector3;

use super::{FRAME_ID, StateRecord};
use crate::geometry::Shape;
use crate::geometry::roots::solve_power_sum;
use crate::state::Species;

/// Distinct colours (Tableau 10), cycled over species.
const PALETTE: [(f64, f64, f64); 10] = [
    (0.122, 0.467, 0.706),
    (1.000, 0.498, 0.055),
    (0.173, 0.627, 0.173),
    (0.839, 0.153, 0.157),
    (0.580, 0.404, 0.741),
    (0.549, 0.337, 0.294),
    (0.890, 0.467, 0.761),
    (0.498, 0.498, 0.498),
    (0.737, 0.741, 0.133),
    (0.090, 0.745, 0.812),
];

/// Latitude and longitude divisions of a superellipsoid mesh.
const MESH_RINGS: usize = 10;
const MESH_SECTORS: usize = 20;

/// Per species: how it is drawn.
#[derive(Debug, Clone)]
struct Look {
    shape: Shape,
    color: Color,
    /// Body-frame mesh (superellipsoids): points and triangle indices.
    mesh: Option<(Vec<Point3>, Vec<u32>)>,
}

/// Builds `/scene` messages for a set of species.
#[derive(Debug, Clone)]
pub struct SceneView {
    looks: Vec<Look>,
}

impl SceneView {
    /// The looks of `species`, meshes made once.
    pub fn new(species: &[Species]) -> Self {
        let looks = species
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let (r, g, b) = PALETTE[i % PALETTE.len()];
                Look {
                    shape: s.shape,
                    color: Color { r, g, b, a: 1.0 },
                    mesh: has_mesh(&s.shape).then(|| body_mesh(&s.shape)),
                }
            })
            .collect();
        Self { looks }
    }

    /// The scene update of a state at `log_time` (ns).
    pub fn update(&self, log_time: u64, state: &StateRecord) -> SceneUpdate {
        let timestamp = Some(Timestamp::new(
            (log_time / 1_000_000_000) as u32,
            (log_time % 1_000_000_000) as u32,
        ));
        let mut particles = SceneEntity {
            timestamp,
            frame_id: FRAME_ID.into(),
            id: "particles".into(),
            ..SceneEntity::default()
        };
        // A frame's own species: a jam stage's and those after it are
        // grown. Their shapes, and the meshes of those that differ from
        // the looks', once per frame.
        let shapes: Vec<Shape> = self
            .looks
            .iter()
            .enumerate()
            .map(|(k, look)| state.species.get(k).map_or(look.shape, |s| s.shape))
            .collect();
        let grown_meshes: Vec<Option<(Vec<Point3>, Vec<u32>)>> = self
            .looks
            .iter()
            .zip(&shapes)
            .map(|(look, shape)| {
                (has_mesh(shape) && *shape != look.shape).then(|| body_mesh(shape))
            })
            .collect();
        for (i, ((p, q), &s)) in (state.positions.iter())
            .zip(&state.orientations)
            .zip(&state.species_of)
            .enumerate()
        {
            let look = &self.looks[s as usize];
            // Polydisperse bodies at their own sizes: primitives of the
            // shape scaled, meshes of the species' shape with their points
            // scaled.
            let factor = state.sizes.as_ref().map_or(1.0, |sizes| sizes[i]);
            let shape = match factor == 1.0 || has_mesh(&shapes[s as usize]) {
                true => shapes[s as usize],
                false => shapes[s as usize].scaled(factor),
            };
            let pose = Some(Pose {
                position: Some(FVector3 {
                    x: p[0],
                    y: p[1],
                    z: p[2],
                }),
                orientation: Some(Quaternion {
                    x: q[1],
                    y: q[2],
                    z: q[3],
                    w: q[0],
                }),
            });
            let color = Some(look.color);
            let size = |h: Vector3<f64>| {
                Some(FVector3 {
                    x: 2.0 * h.x,
                    y: 2.0 * h.y,
                    z: 2.0 * h.z,
                })
            };
            match &shape {
                Shape::Sphere(sp) => particles.spheres.push(SpherePrimitive {
                    pose,
                    size: size(Vector3::repeat(sp.radius())),
                    color,
                }),
                Shape::Ellipsoid(e) => particles.spheres.push(SpherePrimitive {
                    pose,
                    size: size(e.semi_axes()),
                    color,
                }),
                Shape::Cuboid(c) => particles.cubes.push(CubePrimitive {
                    pose,
                    size: size(c.half_extents()),
                    color,
                }),
                Shape::Superellipsoid(_)
                | Shape::Spherocylinder(_)
                | Shape::ConvexPolyhedron(_) => {
                    let (mut points, indices) = grown_meshes[s as usize]
                        .clone()
                        .or_else(|| look.mesh.clone())
                        .expect("made in new()");
                    if factor != 1.0 {
                        for p in &mut points {
                            (p.x, p.y, p.z) = (p.x * factor, p.y * factor, p.z * factor);
                        }
                    }
                    particles.triangles.push(TriangleListPrimitive {
                        pose,
                        points,
                        color,
                        colors: Vec::new(),
                        indices,
                    });
                }
            }
        }
        // The parallelepiped H·s for fractional s = ±1/2 per axis.
        let [lx, ly, lz] = state.box_lengths;
        let [xy, xz, yz] = state.tilts;
        let corner = |i: usize| {
            let s = [1, 2, 4].map(|bit| if i & bit == 0 { -0.5 } else { 0.5 });
            let u = [s[0] * lx, s[1] * ly, s[2] * lz];
            Point3 {
                x: u[0] + xy * u[1] + xz * u[2],
                y: u[1] + yz * u[2],
                z: u[2],
            }
        };
        // The twelve edges: corners differing in one bit.
        let mut points = Vec::with_capacity(24);
        for i in 0..8usize {
            for bit in [1, 2, 4] {
                if i & bit == 0 {
                    points.push(corner(i));
                    points.push(corner(i | bit));
                }
            }
        }
        let edges = SceneEntity {
            timestamp,
            frame_id: FRAME_ID.into(),
            id: "box".into(),
            lines: vec![LinePrimitive {
                r#type: line_primitive::Type::LineList as i32,
                pose: Some(Pose {
                    position: Some(FVector3::default()),
                    orientation: Some(Quaternion {
                        x: 0.0,
                        y: 0.0,
                        z: 0.0,
                        w: 1.0,
                    }),
                }),
                thickness: 2.0,
                scale_invariant: true,
                points,
                color: Some(Color {
                    r: 0.6,
                    g: 0.6,
                    b: 0.6,
                    a: 1.0,
                }),
                colors: Vec::new(),
                indices: Vec::new(),
            }],
            ..SceneEntity::default()
        };
        SceneUpdate {
            deletions: Vec::new(),
            entities: vec![particles, edges],
        }
    }
}

/// Whether the shape is drawn as a triangle mesh (no Foxglove primitive
/// fits it).
fn has_mesh(shape: &Shape) -> bool {
    matches!(
        shape,
        Shape::Superellipsoid(_) | Shape::Spherocylinder(_) | Shape::ConvexPolyhedron(_)
    )
}

/// How far from the centre along the unit direction `u` (body frame) the
/// surface of a body drawn as a mesh lies: for a superellipsoid the t with
/// Σ |t uᵢ / aᵢ|^{eᵢ} = 1; for a spherocylinder (radius r, half-length h)
/// t = r/|u⊥| on the cylinder, else the cap's root of
/// t² − 2th|u_z| + h² − r² = 0.
fn radial_extent(shape: &Shape, u: &Vector3<f64>) -> f64 {
    match shape {
        Shape::Superellipsoid(s) => {
            let (axes, exps) = (s.semi_axes(), s.exponents());
            let c = Vector3::from_fn(|i, _| (u[i] / axes[i]).abs().powf(exps[i]));
            solve_power_sum(&c, &exps)
        }
        Shape::Spherocylinder(s) => {
            let (r, h) = (s.radius(), s.half_length());
            let across = (u.x * u.x + u.y * u.y).sqrt();
            if across * h >= r * u.z.abs() {
                return r / across;
            }
            let along = h * u.z.abs();
            along + (along * along - h * h + r * r).sqrt()
        }
        _ => unreachable!("meshes are made for superellipsoids and spherocylinders only"),
    }
}

/// A body-frame triangle mesh of a body's surface: a polyhedron's faces
/// as fans of triangles; for superellipsoids and spherocylinders,
/// directions on a latitude–longitude grid, each scaled to the surface by
/// [`radial_extent`]; for spheropolyhedra the support points of the
/// grid's directions.
pub(crate) fn body_mesh(shape: &Shape) -> (Vec<Point3>, Vec<u32>) {
    if let Shape::ConvexPolyhedron(p) = shape
        && p.rounding() == 0.0
    {
        let points = (p.corners())
            .map(|v| Point3 {
                x: v.x,
                y: v.y,
                z: v.z,
            })
            .collect();
        let indices = (p.hull().faces().iter())
            .flat_map(|f| {
                (1..f.vertices.len() - 1)
                    .flat_map(move |k| [f.vertices[0], f.vertices[k], f.vertices[k + 1]])
            })
            .map(|i| i as u32)
            .collect();
        return (points, indices);
    }
    let surface = |u: Vector3<f64>| {
        // A spheropolyhedron's grid direction goes to its support point
        // there (its flat faces spanned by the triangles between them).
        let x = match shape {
            Shape::ConvexPolyhedron(p) => p.support(&u),
            _ => u * radial_extent(shape, &u),
        };
        Point3 {
            x: x.x,
            y: x.y,
            z: x.z,
        }
    };
    let mut points = vec![surface(Vector3::z())];
    for ring in 1..MESH_RINGS {
        let theta = std::f64::consts::PI * ring as f64 / MESH_RINGS as f64;
        for sector in 0..MESH_SECTORS {
            let phi = std::f64::consts::TAU * sector as f64 / MESH_SECTORS as f64;
            points.push(surface(Vector3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            )));
        }
    }
    points.push(surface(-Vector3::z()));
    let south = (points.len() - 1) as u32;
    let at =
        |ring: usize, sector: usize| (1 + (ring - 1) * MESH_SECTORS + sector % MESH_SECTORS) as u32;
    let mut indices = Vec::new();
    for sector in 0..MESH_SECTORS {
        indices.extend([0, at(1, sector), at(1, sector + 1)]);
        indices.extend([
            south,
            at(MESH_RINGS - 1, sector + 1),
            at(MESH_RINGS - 1, sector),
        ]);
    }
    for ring in 1..MESH_RINGS - 1 {
        for sector in 0..MESH_SECTORS {
            let (a, b) = (at(ring, sector), at(ring, sector + 1));
            let (c, d) = (at(ring + 1, sector), at(ring + 1, sector + 1));
            indices.extend([a, c, b, b, c, d]);
        }
    }
    (points, indices)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::log::StateRecord;

    #[test]
    fn mesh_points_lie_on_the_surface() {
        let shape: Shape = "Superellipsoid(a: 1.0, b: 0.7, c: 0.5, exponents: (4.0, 4.0, 6.0))"
            .parse()
            .unwrap();
        let (points, indices) = body_mesh(&shape);
        assert_eq!(points.len(), 2 + (MESH_RINGS - 1) * MESH_SECTORS);
        assert_eq!(indices.len() % 3, 0);
        assert!(indices.iter().all(|&i| (i as usize) < points.len()));
        let Shape::Superellipsoid(s) = shape else {
            unreachable!()
        };
        let (a, e) = (s.semi_axes(), s.exponents());
        for p in points {
            let v = [p.x, p.y, p.z];
            let f: f64 = (0..3).map(|i| (v[i] / a[i]).abs().powf(e[i])).sum();
            assert!((f - 1.0).abs() < 1e-9, "{f}");
        }
    }

    /// A spherocylinder's mesh points lie at its radius from its axis
    /// segment, on the cylinder and on the caps alike.
    #[test]
    fn spherocylinder_mesh_points_lie_on_the_surface() {
        let shape: Shape = "Spherocylinder(radius: 0.4, length: 1.5)".parse().unwrap();
        let Shape::Spherocylinder(rod) = shape else {
            unreachable!()
        };
        let (points, _) = body_mesh(&shape);
        let (mut on_caps, mut on_cylinder) = (0, 0);
        for p in points {
            let x = Vector3::new(p.x, p.y, p.z);
            let axis = Vector3::new(0.0, 0.0, x.z.clamp(-rod.half_length(), rod.half_length()));
            let d = (x - axis).norm();
            assert!((d - rod.radius()).abs() < 1e-12, "{x}: {d}");
            if x.z.abs() > rod.half_length() {
                on_caps += 1;
            } else {
                on_cylinder += 1;
            }
        }
        assert!(on_caps > 0 && on_cylinder > 0, "{on_caps} {on_cylinder}");
    }

    #[test]
    fn one_entity_holds_every_particle_with_its_pose() {
        let species: Vec<Species> = [
            "Ellipsoid(a: 1.0, b: 0.5, c: 0.25)",
            "Cuboid(a: 0.5, b: 0.5, c: 0.5)",
        ]
        .iter()
        .map(|t| Species {
            name: t.to_string(),
            shape: t.parse().unwrap(),
            rotation: true,
        })
        .collect();
        let state = StateRecord {
            stage_index: 0,
            stage: "compress".into(),
            sweep: Some(0),
            time: None,
            box_lengths: [10.0, 10.0, 10.0],
            tilts: [0.0; 3],
            species: Vec::new(),
            species_of: vec![0, 1, 0],
            positions: vec![[1.0, 2.0, 3.0], [0.0, 0.0, 0.0], [-1.0, -2.0, -3.0]],
            orientations: vec![
                [0.5, 0.5, 0.5, 0.5],
                [1.0, 0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0, 0.0],
            ],
            sizes: None,
            velocities: None,
            angular_velocities: None,
            resume: None,
        };
        let u = SceneView::new(&species).update(1_500_000_000, &state);
        assert_eq!(u.entities.len(), 2);
        let p = &u.entities[0];
        assert_eq!((p.spheres.len(), p.cubes.len()), (2, 1));
        let s = p.spheres[0];
        assert_eq!(s.size.unwrap().z, 0.5);
        // [w, x, y, z] → Foxglove's {x, y, z, w}.
        let q = s.pose.unwrap().orientation.unwrap();
        assert_eq!((q.w, q.x), (0.5, 0.5));
        assert_eq!(u.entities[1].lines[0].points.len(), 24);
        assert_eq!(p.timestamp, Some(Timestamp::new(1, 500_000_000)));
    }

    #[test]
    fn a_frame_with_grown_species_is_drawn_at_their_size() {
        let shapes: [Shape; 2] = [
            "Superellipsoid(a: 0.5, b: 0.4, c: 0.3, exponents: (4.0, 4.0, 4.0))"
                .parse()
                .unwrap(),
            "Sphere(radius: 0.5)".parse().unwrap(),
        ];
        let species = |factor: f64| -> Vec<Species> {
            shapes
                .iter()
                .map(|s| Species {
                    name: s.kind().into(),
                    shape: s.scaled(factor),
                    rotation: true,
                })
                .collect()
        };
        let state = StateRecord {
            stage_index: 1,
            stage: "jam".into(),
            sweep: None,
            time: Some(1.0),
            box_lengths: [10.0, 10.0, 10.0],
            tilts: [0.0; 3],
            species: species(1.5)
                .into_iter()
                .map(|s| crate::log::SpeciesRecord {
                    name: s.name,
                    shape: s.shape,
                    rotation: s.rotation,
                })
                .collect(),
            species_of: vec![0, 1],
            positions: vec![[1.0, 2.0, 3.0], [0.0, 0.0, 0.0]],
            orientations: vec![[1.0, 0.0, 0.0, 0.0]; 2],
            sizes: None,
            velocities: None,
            angular_velocities: None,
            resume: None,
        };
        let view = SceneView::new(&species(1.0));
        let u = view.update(0, &state);
        let p = &u.entities[0];
        assert_eq!(p.spheres[0].size.unwrap().x, 1.5);
        let farthest = |points: &[Point3]| points.iter().map(|q| q.x.abs()).fold(0.0, f64::max);
        assert!((farthest(&p.triangles[0].points) - 0.75).abs() < 1e-12);
        // A frame without species of its own is drawn with the log's.
        let plain = view.update(
            0,
            &StateRecord {
                species: Vec::new(),
                ..state
            },
        );
        assert_eq!(plain.entities[0].spheres[0].size.unwrap().x, 1.0);
        assert!((farthest(&plain.entities[0].triangles[0].points) - 0.5).abs() < 1e-12);
    }
}
