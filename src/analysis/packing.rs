//! The contact network of a packing: which bodies touch (their exact
//! signed distance within a gap tolerance), the rattlers (bodies whose
//! contacts cannot hold them, removed one round after another), and the
//! mean contact number of the backbone that remains, against the
//! isostatic value 2 d_f (d_f = 3 for spheres, 5 for bodies of
//! revolution, 6 for other bodies; Donev, Torquato & Stillinger).
//!
//! A body is a rattler when, its neighbours held still, its contacts
//! cannot block every translation: when their normals all lie in one
//! closed hemisphere, some direction moves it away from or along every
//! contact. For spheres this is local jamming (Torquato & Stillinger, J.
//! Phys. Chem. B 105, 11849 (2001)): at least d + 1 = 4 contacts, not
//! all on one side. Rotations are not tested: bodies in the hypostatic
//! packings of ellipsoids and superballs are held against rotation by
//! the curvature of their surfaces at second order, not by first-order
//! constraints (Donev, Connelly, Stillinger & Torquato, Phys. Rev. E 75,
//! 051304 (2007)), so a first-order test of rotations, like counting
//! d_f + 1 contacts, would call every body of such a packing a rattler.
//!
//! Two flat bodies can touch along a line or over a face, and such a
//! contact holds them as two or three point contacts would (an edge on a
//! face stops two motions, a face on a face three): contacts are counted
//! as the constraints they impose, 1, 2 or 3, in the rattler rule and in
//! the mean that is set against the isostatic value (the counting of
//! frictionless polyhedra, e.g. Smith, Alam & Fisher, Phys. Rev. E 82,
//! 011304 (2010)). For curved bodies every contact is a point, one
//! constraint.

use nalgebra::{UnitQuaternion, Vector3};
use serde::Serialize;

use crate::geometry::pair::contact_patch;
use crate::geometry::{Contact, DistanceOptions, Relative, Shape, distance};
use crate::space::{PeriodicBox, pairs_within};

type V3 = Vector3<f64>;

/// One body of a packing: centre, orientation, index of its shape.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PackedBody {
    /// Centre.
    pub position: V3,
    /// Body → lab rotation.
    pub orientation: UnitQuaternion<f64>,
    /// Index into the shapes.
    pub shape: usize,
}

/// The shapes a packing's bodies have, whether each turns, and each body's
/// index into them: body i of species `species_of[i]` has the species'
/// shape (`shapes[k]`, turning as `turns[k]`), or, where the bodies have
/// sizes of their own, a shape of its own scaled by `sizes[i]`.
pub fn body_shapes(
    shapes: &[Shape],
    turns: &[bool],
    species_of: &[usize],
    sizes: Option<&[f64]>,
) -> (Vec<Shape>, Vec<bool>, Vec<usize>) {
    match sizes {
        Some(sizes) => (
            (species_of.iter().zip(sizes))
                .map(|(&k, &f)| shapes[k].scaled(f))
                .collect(),
            species_of.iter().map(|&k| turns[k]).collect(),
            (0..species_of.len()).collect(),
        ),
        None => (shapes.to_vec(), turns.to_vec(), species_of.to_vec()),
    }
}

/// The contact network of a packing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ContactNetwork {
    /// Bodies.
    pub bodies: usize,
    /// Σ body volume / box volume.
    pub packing_fraction: f64,
    /// The gap below which two bodies count as touching, relative to the
    /// smaller of the two bodies' smallest half-extents.
    pub gap_tolerance: f64,
    /// The touching pairs (i < j).
    pub contacts: Vec<(usize, usize)>,
    /// The constraints each contact imposes: 1 at a point, 2 along a line
    /// (an edge on a face), 3 over a face.
    pub constraints: Vec<usize>,
    /// Pairs found overlapping (by more than the tolerance): a packing
    /// that is not valid.
    pub overlaps: usize,
    /// Contacts per body.
    pub contact_numbers: Vec<usize>,
    /// Constraints per body (the contact numbers, for curved bodies).
    pub constraint_numbers: Vec<usize>,
    /// Bodies whose contacts with the bodies left cannot block their
    /// translations, removed round after round.
    pub rattlers: Vec<usize>,
    /// Mean contacts per body of the backbone (the bodies left), 2 C / N.
    pub backbone_contact_number: f64,
    /// Mean constraints per body of the backbone: what is set against
    /// the isostatic number (the contact number, for curved bodies).
    pub backbone_constraint_number: f64,
    /// Mean contacts per body over all bodies, rattlers included.
    pub mean_contact_number: f64,
    /// Mean constraints per body over all bodies.
    pub mean_constraint_number: f64,
    /// 2 d_f averaged over the backbone: the isostatic contact number.
    pub isostatic_contact_number: f64,
    /// How many bodies have 0, 1, 2, ... contacts (all bodies).
    pub contact_number_histogram: Vec<usize>,
}

/// Which bodies are rattlers (see the module's notes): round after round,
/// those whose contacts with the bodies left cannot block their
/// translations. `normals[k]` is contact k's normal, pointing from its
/// first body to its second.
fn rattlers(n: usize, contacts: &[(usize, usize)], normals: &[V3]) -> Vec<bool> {
    let mut touching: Vec<Vec<(usize, V3)>> = vec![Vec::new(); n];
    for (&(i, j), normal) in contacts.iter().zip(normals) {
        touching[i].push((j, *normal));
        touching[j].push((i, -normal));
    }
    let mut rattler = vec![false; n];
    let mut towards = Vec::new();
    loop {
        let newly: Vec<usize> = (0..n)
            .filter(|&i| !rattler[i])
            .filter(|&i| {
                towards.clear();
                towards.extend(
                    touching[i]
                        .iter()
                        .filter(|(j, _)| !rattler[*j])
                        .map(|(_, normal)| *normal),
                );
                in_closed_hemisphere(&towards)
            })
            .collect();
        if newly.is_empty() {
            return rattler;
        }
        for i in newly {
            rattler[i] = true;
        }
    }
}

/// Whether the directions `towards` (to a body's contacts) all lie in one
/// closed hemisphere: then some translation moves the body away from or
/// along every contact, and nothing holds it. Fewer than four always do.
/// Such a hemisphere, if there is one, can be turned until its rim passes
/// through two of the directions: its pole is ± their cross product
/// (or, were they all parallel, any direction across them).
fn in_closed_hemisphere(towards: &[V3]) -> bool {
    const ROUND_OFF: f64 = 1e-9;
    if towards.len() < 4 {
        return true;
    }
    let one_side = |pole: &V3| {
        towards.iter().all(|u| pole.dot(u) >= -ROUND_OFF)
            || towards.iter().all(|u| pole.dot(u) <= ROUND_OFF)
    };
    let mut any_pole = false;
    for (k, a) in towards.iter().enumerate() {
        for b in &towards[k + 1..] {
            let pole = a.cross(b);
            let length = pole.norm();
            if length > ROUND_OFF {
                any_pole = true;
                if one_side(&(pole / length)) {
                    return true;
                }
            }
        }
    }
    // All parallel or opposite: free across them.
    !any_pole
}

/// Degrees of freedom of a rigid body of this shape whose rotations
/// change its contacts: 3 for a sphere, 5 for a body of revolution whose
/// axis is all that matters (a spheroid, a superellipsoid of revolution
/// with exponent 2 about its axis), 6 otherwise.
pub fn degrees_of_freedom(shape: &Shape) -> usize {
    let close = |x: f64, y: f64| (x - y).abs() <= 1e-12 * x.abs().max(y.abs());
    // The pairs of body axes the shape is round about (equal semi-axes,
    // and for a superellipsoid exponent 2 along both).
    let round = |axes: V3, exponents: V3| {
        [(0, 1), (1, 2), (0, 2)]
            .into_iter()
            .filter(|&(i, j)| close(axes[i], axes[j]) && exponents[i] == 2.0 && exponents[j] == 2.0)
            .count()
    };
    let rounds = match shape {
        Shape::Sphere(_) => 3,
        Shape::Ellipsoid(e) => round(e.semi_axes(), V3::repeat(2.0)),
        Shape::Superellipsoid(s) => round(s.semi_axes(), s.exponents()),
        Shape::Cuboid(_) | Shape::ConvexPolyhedron(_) => 0,
        // Round about its axis only.
        Shape::Spherocylinder(_) => 1,
    };
    match rounds {
        3 => 3,
        1 => 5,
        _ => 6,
    }
}

/// The constraints a contact over the region with corners `points`
/// imposes: 1 for a point (or no region), 2 for a segment, 3 for an area,
/// lengths below `tolerance` taken for zero (two coplanar faces that
/// meet along an edge share a region of no width).
fn constraints_of(points: &[V3], tolerance: f64) -> usize {
    let farthest = |from: &V3, far: &dyn Fn(&V3) -> f64| {
        points
            .iter()
            .map(|p| (far(p), *p))
            .fold(
                (f64::NEG_INFINITY, *from),
                |a, b| if b.0 > a.0 { b } else { a },
            )
    };
    let Some(first) = points.first() else {
        return 1;
    };
    let (length, end) = farthest(first, &|p| (p - first).norm());
    if length <= tolerance {
        return 1;
    }
    let along = (end - first) / length;
    let (width, _) = farthest(first, &|p| {
        let r = p - first;
        (r - along * r.dot(&along)).norm()
    });
    if width <= tolerance { 2 } else { 3 }
}

/// Calls `f(i, j, scale, relative pose, contact)` for every pair of
/// `bodies` (shapes `shapes`) in `box_` whose bounding spheres come
/// within `max_gap` times `scale`, the smaller of the two bodies'
/// smallest half-extents; the contact is their exact signed distance.
pub fn near_pairs(
    box_: &PeriodicBox,
    shapes: &[Shape],
    bodies: &[PackedBody],
    max_gap: f64,
    mut f: impl FnMut(usize, usize, f64, &Relative, &Contact),
) {
    let options = DistanceOptions::default();
    let largest = shapes
        .iter()
        .map(Shape::bounding_radius)
        .fold(0.0, f64::max);
    let thickest = shapes
        .iter()
        .map(Shape::min_half_extent)
        .fold(0.0, f64::max);
    let centres: Vec<_> = bodies.iter().map(|b| b.position).collect();
    pairs_within(
        box_,
        &centres,
        2.0 * largest + max_gap * thickest,
        |i, j, d| {
            let (a, b) = (&bodies[i], &bodies[j]);
            let (shape_a, shape_b) = (&shapes[a.shape], &shapes[b.shape]);
            let scale = shape_a.min_half_extent().min(shape_b.min_half_extent());
            let reach = shape_a.bounding_radius() + shape_b.bounding_radius() + max_gap * scale;
            if d.norm_squared() > reach * reach {
                return;
            }
            let rel = Relative::new(&d, &a.orientation, &b.orientation);
            let contact = distance(shape_a, shape_b, &rel, &options, None);
            f(i, j, scale, &rel, &contact);
        },
    );
}

/// The contact network of `bodies` (shapes `shapes`, all turning) in
/// `box_`: bodies touch where their signed distance is below
/// `gap_tolerance` times the smaller of their smallest half-extents.
pub fn contact_network(
    box_: &PeriodicBox,
    shapes: &[Shape],
    bodies: &[PackedBody],
    gap_tolerance: f64,
) -> ContactNetwork {
    contact_network_turning(
        box_,
        shapes,
        &vec![true; shapes.len()],
        bodies,
        gap_tolerance,
    )
}

/// [`contact_network`] where the bodies of shape k turn only if
/// `turns[k]`: those that do not have 3 degrees of freedom, whatever
/// their shape.
pub fn contact_network_turning(
    box_: &PeriodicBox,
    shapes: &[Shape],
    turns: &[bool],
    bodies: &[PackedBody],
    gap_tolerance: f64,
) -> ContactNetwork {
    let n = bodies.len();
    let mut contacts = Vec::new();
    let mut overlaps = 0;
    near_pairs(
        box_,
        shapes,
        bodies,
        gap_tolerance,
        |i, j, scale, rel, contact| {
            let tolerance = gap_tolerance * scale;
            if contact.distance < -tolerance {
                overlaps += 1;
            }
            if contact.distance < tolerance {
                let (a, b) = (&bodies[i], &bodies[j]);
                let (shape_a, shape_b) = (&shapes[a.shape], &shapes[b.shape]);
                let patch = contact_patch(shape_a, shape_b, rel, &contact.normal, tolerance);
                // From A's body frame to the lab's.
                let normal = a.orientation * contact.normal;
                let normal = [normal.x, normal.y, normal.z];
                contacts.push((i, j, constraints_of(patch.points(), tolerance), normal));
            }
        },
    );
    // In index order, whatever order the cells gave them in.
    contacts.sort_unstable_by_key(|c| (c.0, c.1));
    let constraints: Vec<usize> = contacts.iter().map(|c| c.2).collect();
    let normals: Vec<V3> = contacts.iter().map(|c| V3::from(c.3)).collect();
    let contacts: Vec<(usize, usize)> = contacts.iter().map(|c| (c.0, c.1)).collect();
    let mut contact_numbers = vec![0; n];
    let mut constraint_numbers = vec![0; n];
    for (&(i, j), &c) in contacts.iter().zip(&constraints) {
        contact_numbers[i] += 1;
        contact_numbers[j] += 1;
        constraint_numbers[i] += c;
        constraint_numbers[j] += c;
    }
    let freedom: Vec<usize> = bodies
        .iter()
        .map(|b| {
            if turns[b.shape] {
                degrees_of_freedom(&shapes[b.shape])
            } else {
                3
            }
        })
        .collect();
    let rattler = rattlers(n, &contacts, &normals);
    let backbone: Vec<usize> = (0..n).filter(|&i| !rattler[i]).collect();
    let in_backbone = |&(i, j): &(usize, usize)| !rattler[i] && !rattler[j];
    let backbone_contacts = contacts.iter().filter(|c| in_backbone(c)).count();
    let backbone_constraints: usize = contacts
        .iter()
        .zip(&constraints)
        .filter(|(c, _)| in_backbone(c))
        .map(|(_, &k)| k)
        .sum();
    let per_body = |total: f64| {
        if backbone.is_empty() {
            f64::NAN
        } else {
            total / backbone.len() as f64
        }
    };
    let mut histogram = vec![0; contact_numbers.iter().max().map_or(0, |m| m + 1)];
    for &z in &contact_numbers {
        histogram[z] += 1;
    }
    let volume: f64 = bodies.iter().map(|b| shapes[b.shape].volume()).sum();
    ContactNetwork {
        bodies: n,
        packing_fraction: volume / box_.volume(),
        gap_tolerance,
        overlaps,
        contact_numbers,
        constraint_numbers,
        rattlers: (0..n).filter(|&i| rattler[i]).collect(),
        backbone_contact_number: per_body(2.0 * backbone_contacts as f64),
        backbone_constraint_number: per_body(2.0 * backbone_constraints as f64),
        mean_contact_number: 2.0 * contacts.len() as f64 / n.max(1) as f64,
        mean_constraint_number: 2.0 * constraints.iter().sum::<usize>() as f64 / n.max(1) as f64,
        isostatic_contact_number: per_body(backbone.iter().map(|&i| 2.0 * freedom[i] as f64).sum()),
        contact_number_histogram: histogram,
        contacts,
        constraints,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::{Cuboid, Ellipsoid, Sphere, Superellipsoid};

    fn sphere(r: f64) -> Shape {
        Shape::Sphere(Sphere::new(r).unwrap())
    }

    fn at(x: f64, y: f64, z: f64) -> PackedBody {
        PackedBody {
            position: V3::new(x, y, z),
            orientation: UnitQuaternion::identity(),
            shape: 0,
        }
    }

    /// 64 bodies on the simple-cubic lattice of spacing 1 filling a box
    /// of edge 4.
    fn simple_cubic_4() -> Vec<PackedBody> {
        (0..64)
            .map(|s| {
                at(
                    (s % 4) as f64 - 1.5,
                    ((s / 4) % 4) as f64 - 1.5,
                    (s / 16) as f64 - 1.5,
                )
            })
            .collect()
    }

    /// The close-packed fcc crystal: every sphere touches twelve, none is
    /// a rattler, φ = π/√18.
    #[test]
    fn fcc_spheres_touch_twelve() {
        let cells = 4;
        let a = 2f64.sqrt(); // cube edge for diameter 1
        let side = cells as f64 * a;
        let box_ = PeriodicBox::new(V3::repeat(side)).unwrap();
        let basis = [
            [0.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.5],
            [0.0, 0.5, 0.5],
        ];
        let mut bodies = Vec::new();
        for (i, j, k) in (0..cells)
            .flat_map(|i| (0..cells).flat_map(move |j| (0..cells).map(move |k| (i, j, k))))
        {
            for b in basis {
                let p = (V3::new(i as f64, j as f64, k as f64) + V3::from(b)) * a;
                bodies.push(at(p.x - side / 2.0, p.y - side / 2.0, p.z - side / 2.0));
            }
        }
        let network = contact_network(&box_, &[sphere(0.5)], &bodies, 1e-6);
        assert!(network.contact_numbers.iter().all(|&z| z == 12));
        assert!(network.rattlers.is_empty());
        assert_eq!(network.overlaps, 0);
        assert!((network.backbone_contact_number - 12.0).abs() < 1e-12);
        assert_eq!(network.isostatic_contact_number, 6.0);
        assert!((network.packing_fraction - std::f64::consts::PI / 18f64.sqrt()).abs() < 1e-12);
    }

    /// Spheres on a simple-cubic lattice touch six each: too few for
    /// nothing (six is more than d_f + 1 = 4), and a gap just over the
    /// tolerance is no contact.
    #[test]
    fn simple_cubic_spheres_touch_six_and_a_gap_is_no_contact() {
        let box_ = PeriodicBox::new(V3::repeat(4.0)).unwrap();
        let bodies = simple_cubic_4();
        let touching = contact_network(&box_, &[sphere(0.5)], &bodies, 1e-6);
        assert!(touching.contact_numbers.iter().all(|&z| z == 6));
        assert_eq!(touching.contacts.len(), 64 * 3);
        let apart = contact_network(&box_, &[sphere(0.5 - 1e-5)], &bodies, 1e-6);
        assert!(apart.contacts.is_empty());
        assert_eq!(apart.rattlers.len(), 64);
        assert!(apart.backbone_contact_number.is_nan());
    }

    /// Removing a rattler can free its neighbours: a sphere touching four
    /// others at the corners of a tetrahedron, which touch only it, is
    /// held in the first round and freed in the second.
    #[test]
    fn rattlers_go_round_after_round() {
        let box_ = PeriodicBox::new(V3::repeat(20.0)).unwrap();
        let corners = [
            V3::new(1.0, 1.0, 1.0),
            V3::new(1.0, -1.0, -1.0),
            V3::new(-1.0, 1.0, -1.0),
            V3::new(-1.0, -1.0, 1.0),
        ];
        let mut bodies = vec![at(0.0, 0.0, 0.0)];
        bodies.extend(corners.iter().map(|c| {
            let p = c.normalize();
            at(p.x, p.y, p.z)
        }));
        let network = contact_network(&box_, &[sphere(0.5)], &bodies, 1e-6);
        assert_eq!(network.contact_numbers, vec![4, 1, 1, 1, 1]);
        assert_eq!(network.rattlers, vec![0, 1, 2, 3, 4]);
        assert_eq!(network.contact_number_histogram, vec![0, 4, 0, 0, 1]);
        assert_eq!(network.overlaps, 0);
        let contacts = [0, 1, 2, 3].map(|k| (0, k + 1));
        let normals = corners.map(|c| c.normalize());
        let direct = rattlers(5, &contacts, &normals[..]);
        assert_eq!(direct, vec![true; 5]);
    }

    /// Four or more contacts hold a sphere only if they do not all lie on
    /// one side: the tetrahedron's corners do, five directions of the
    /// upper half space and four in a plane do not.
    #[test]
    fn contacts_on_one_side_hold_nothing() {
        let tetrahedron = [
            V3::new(1.0, 1.0, 1.0),
            V3::new(1.0, -1.0, -1.0),
            V3::new(-1.0, 1.0, -1.0),
            V3::new(-1.0, -1.0, 1.0),
        ]
        .map(|c| c.normalize());
        assert!(!in_closed_hemisphere(&tetrahedron));
        let upper = [
            V3::new(0.0, 0.0, 1.0),
            V3::new(1.0, 0.0, 0.2),
            V3::new(-1.0, 0.0, 0.2),
            V3::new(0.0, 1.0, 0.2),
            V3::new(0.0, -1.0, 0.0),
        ]
        .map(|c| c.normalize());
        assert!(in_closed_hemisphere(&upper));
        let plane = [V3::x(), -V3::x(), V3::y(), -V3::y()];
        assert!(in_closed_hemisphere(&plane));
        let octahedron = [V3::x(), -V3::x(), V3::y(), -V3::y(), V3::z(), -V3::z()];
        assert!(!in_closed_hemisphere(&octahedron));
        assert!(in_closed_hemisphere(&tetrahedron[..3]));
        assert!(in_closed_hemisphere(&[
            V3::x(),
            -V3::x(),
            V3::x(),
            -V3::x()
        ]));
    }

    /// Overlapping pairs are contacts and are counted as overlaps.
    #[test]
    fn an_overlap_is_a_contact_and_is_counted() {
        let box_ = PeriodicBox::new(V3::repeat(20.0)).unwrap();
        let bodies = [at(0.0, 0.0, 0.0), at(1.0, 0.0, 0.0), at(1.9, 0.0, 0.0)];
        let network = contact_network(&box_, &[sphere(0.5)], &bodies, 1e-6);
        assert_eq!(network.contacts, vec![(0, 1), (1, 2)]);
        assert_eq!(network.overlaps, 1);
    }

    /// A contact of two cubes imposes as many constraints as the points
    /// it takes to hold them there: a face on a face 3, an edge on a face
    /// 2, a corner on a face 1. Four cubes each held by only its face
    /// contact with a fifth (3 constraints each, fewer than d_f + 1 = 7)
    /// are rattlers, and then so is the fifth.
    #[test]
    fn cube_contacts_count_the_constraints_they_impose() {
        let cube = Shape::Cuboid(Cuboid::new(0.5, 0.5, 0.5).unwrap());
        let box_ = PeriodicBox::new(V3::repeat(20.0)).unwrap();
        let turned = |axis: V3, angle: f64, p: V3| PackedBody {
            position: p,
            orientation: UnitQuaternion::from_axis_angle(
                &nalgebra::Unit::new_normalize(axis),
                angle,
            ),
            shape: 0,
        };
        let half_diagonal = 0.5 * 2f64.sqrt();
        let body_diagonal = 0.5 * 3f64.sqrt();
        let pairs = [
            // Face on face, offset sideways.
            (at(0.3, 0.2, 1.0), 3),
            // Turned 45° about x: an edge along x rests on the top face.
            (
                turned(
                    V3::x(),
                    std::f64::consts::FRAC_PI_4,
                    V3::new(0.2, 0.1, 0.5 + half_diagonal),
                ),
                2,
            ),
            // A body diagonal along z: a corner rests on the top face.
            (
                turned(
                    V3::new(1.0, -1.0, 0.0),
                    (1.0 / 3f64.sqrt()).acos(),
                    V3::new(0.1, 0.0, 0.5 + body_diagonal),
                ),
                1,
            ),
        ];
        for (top, expected) in pairs {
            let network = contact_network(&box_, &[cube], &[at(0.0, 0.0, 0.0), top], 1e-9);
            assert_eq!(network.contacts, vec![(0, 1)], "{:?}", top.orientation);
            assert_eq!(network.constraints, vec![expected], "{:?}", top.orientation);
            assert_eq!(network.constraint_numbers, vec![expected; 2]);
            assert_eq!(network.contact_numbers, vec![1, 1]);
        }
        // Slid along the faces they touch so that they touch no other.
        let bodies = [
            at(0.0, 0.0, 0.0),
            at(1.0, -0.3, 0.0),
            at(-1.0, 0.3, 0.0),
            at(0.3, 1.0, 0.0),
            at(-0.3, -1.0, 0.0),
        ];
        let network = contact_network(&box_, &[cube], &bodies, 1e-9);
        assert_eq!(network.constraint_numbers, vec![12, 3, 3, 3, 3]);
        assert_eq!(network.rattlers, vec![0, 1, 2, 3, 4]);
        assert!(network.backbone_constraint_number.is_nan());
        assert_eq!(network.mean_contact_number, 8.0 / 5.0);
        assert_eq!(network.mean_constraint_number, 24.0 / 5.0);
    }

    /// Cubes face to face on a lattice touch their 26 neighbours (faces,
    /// edges and corners all at distance zero); rotated by 45° about z
    /// and spread they touch none.
    #[test]
    fn cubes_touch_by_faces_edges_and_corners() {
        let cube = Shape::Cuboid(Cuboid::new(0.5, 0.5, 0.5).unwrap());
        let box_ = PeriodicBox::new(V3::repeat(4.0)).unwrap();
        let bodies = simple_cubic_4();
        let network = contact_network(&box_, &[cube], &bodies, 1e-6);
        assert!(
            network.contact_numbers.iter().all(|&z| z == 26),
            "{:?}",
            &network.contact_numbers[..4]
        );
        assert_eq!(network.isostatic_contact_number, 12.0);
        assert!((network.packing_fraction - 1.0).abs() < 1e-12);
    }

    /// Bodies that do not turn have three degrees of freedom, whatever
    /// their shape.
    #[test]
    fn frozen_bodies_count_three_degrees_of_freedom() {
        let box_ = PeriodicBox::new(V3::repeat(4.0)).unwrap();
        let cube = Shape::Cuboid(Cuboid::new(0.5, 0.5, 0.5).unwrap());
        let bodies = simple_cubic_4();
        let turning = contact_network_turning(&box_, &[cube], &[true], &bodies, 1e-6);
        let frozen = contact_network_turning(&box_, &[cube], &[false], &bodies, 1e-6);
        assert_eq!(turning.contacts, frozen.contacts);
        assert_eq!(frozen.isostatic_contact_number, 6.0);
        assert_eq!(turning.isostatic_contact_number, 12.0);
    }

    #[test]
    fn degrees_of_freedom_by_shape() {
        let e = |a, b, c| Shape::Ellipsoid(Ellipsoid::new(a, b, c).unwrap());
        assert_eq!(degrees_of_freedom(&sphere(1.0)), 3);
        assert_eq!(degrees_of_freedom(&e(1.0, 1.0, 1.0)), 3);
        assert_eq!(degrees_of_freedom(&e(2.0, 1.0, 1.0)), 5);
        assert_eq!(degrees_of_freedom(&e(1.25, 1.0, 0.8)), 6);
        let sup = |x| Shape::Superellipsoid(Superellipsoid::new(1.0, 1.0, 2.0, x).unwrap());
        assert_eq!(degrees_of_freedom(&sup((2.0, 2.0, 4.0))), 5);
        assert_eq!(degrees_of_freedom(&sup((4.0, 4.0, 2.0))), 6);
        assert_eq!(
            degrees_of_freedom(&Shape::Cuboid(Cuboid::new(1.0, 1.0, 2.0).unwrap())),
            6
        );
    }
}
