//! Crystal starts: a unit cell (lattice vectors, basis sites, their
//! orientations) repeated into a supercell that becomes the periodic box,
//! scaled to a packing fraction. The supercell is rotated so that its
//! first vector lies along x and its second in the xy plane (the box's
//! convention, see [`PeriodicBox`]); bodies turn with it.

use nalgebra::{Matrix3, UnitQuaternion, Vector3};

use super::{Particle, Species, StateError, System};
use crate::geometry::{Relative, overlap};
use crate::space::PeriodicBox;

type V3 = Vector3<f64>;

/// A unit cell: lattice vectors (columns, any length unit: the start
/// scales them), basis sites in fractional coordinates, and the
/// orientation of the body on each site (body → lattice frame).
#[derive(Debug, Clone, PartialEq)]
pub struct UnitCell {
    /// Lattice vectors a₁, a₂, a₃ as columns.
    pub vectors: Matrix3<f64>,
    /// Sites, fractional.
    pub basis: Vec<V3>,
    /// One per site.
    pub orientations: Vec<UnitQuaternion<f64>>,
}

/// Why a crystal cannot be built.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CrystalError {
    /// Lattice vectors that span no volume, or span it left-handed.
    #[error(
        "lattice vectors must be right-handed and span a volume (a1 . (a2 x a3) > 0), got {0:.6e} (relative to their lengths)"
    )]
    Degenerate(f64),
    /// Not three lattice vectors.
    #[error("a lattice takes 3 vectors, got {0}")]
    Vectors(usize),
    /// An orientation quaternion of zero or non-finite norm.
    #[error(
        "orientation {0} is not a quaternion that can be normalised (its norm is zero or not finite)"
    )]
    Orientation(usize),
    /// A basis with no sites, or orientations not one per site.
    #[error(
        "the basis has {sites} sites and {orientations} orientations: give at least one site and one orientation per site (or none)"
    )]
    Basis {
        /// Sites given.
        sites: usize,
        /// Orientations given.
        orientations: usize,
    },
    /// A basis site outside [0, 1) or not finite.
    #[error("basis site {0} has fractional coordinates outside [0, 1): {1:?}")]
    SiteOutside(usize, [f64; 3]),
    /// A cell count of zero.
    #[error("cells must be at least 1 along each vector, got {0:?}")]
    NoCells([usize; 3]),
    /// The species do not fill the sites.
    #[error(
        "the crystal has {sites} sites ({basis} per cell x {cells:?} cells) but the species count {particles} particles: make the counts add up to the sites"
    )]
    Count {
        /// Sites in the supercell.
        sites: usize,
        /// Sites per cell.
        basis: usize,
        /// Cells along each vector.
        cells: [usize; 3],
        /// Particles the species count.
        particles: usize,
    },
    /// The bodies overlap at the requested packing fraction.
    #[error(
        "packing fraction {asked} is above what this lattice allows: its bodies touch at {limit:.10}"
    )]
    TooDense {
        /// The packing fraction asked for.
        asked: f64,
        /// Where the bodies touch.
        limit: f64,
    },
    /// Two sites whose bodies overlap at any density.
    #[error("basis sites overlap at any packing fraction (two sites coincide)")]
    Coincident,
    /// Bodies whose lattice cannot be computed in floating point: no scale
    /// at which they touch was found (sizes near the end of the float
    /// range).
    #[error(
        "no scale at which the bodies touch could be found (bounding radius {0:e}): their sizes are outside what floating point can place on a lattice"
    )]
    Scale(f64),
    /// No densest lattice is known here for this shape.
    #[error("no densest lattice is known to hardbody for {0}: give a Custom lattice")]
    NoDensest(String),
    /// A packing fraction outside (0, 1].
    #[error("packing fraction must lie in (0, 1], got {0}")]
    PackingFraction(f64),
    /// The system the crystal makes is unusable (a box thinner than twice
    /// the largest body).
    #[error(transparent)]
    System(#[from] StateError),
}

impl UnitCell {
    /// One site at the origin of a unit cube.
    pub fn simple_cubic() -> Self {
        Self::cubic(&[[0.0; 3]])
    }

    /// The conventional cubic cell of body-centred cubic (2 sites).
    pub fn bcc() -> Self {
        Self::cubic(&[[0.0; 3], [0.5; 3]])
    }

    /// The conventional cubic cell of face-centred cubic (4 sites).
    pub fn fcc() -> Self {
        Self::cubic(&[
            [0.0, 0.0, 0.0],
            [0.5, 0.5, 0.0],
            [0.5, 0.0, 0.5],
            [0.0, 0.5, 0.5],
        ])
    }

    /// Hexagonal close packing in its orthorhombic cell (1 × √3 × √(8/3),
    /// 4 sites: layers A at z = 0 and B at z = 1/2), ideal c/a.
    pub fn hcp() -> Self {
        Self::aligned(
            Matrix3::from_diagonal(&V3::new(1.0, 3f64.sqrt(), (8.0f64 / 3.0).sqrt())),
            &[
                [0.0, 0.0, 0.0],
                [0.5, 0.5, 0.0],
                [0.5, 1.0 / 6.0, 0.5],
                [0.0, 2.0 / 3.0, 0.5],
            ],
        )
    }

    fn cubic(sites: &[[f64; 3]]) -> Self {
        Self::aligned(Matrix3::identity(), sites)
    }

    pub(super) fn aligned(vectors: Matrix3<f64>, sites: &[[f64; 3]]) -> Self {
        Self {
            vectors,
            basis: sites.iter().map(|s| V3::from(*s)).collect(),
            orientations: vec![UnitQuaternion::identity(); sites.len()],
        }
    }

    /// Checks what makes a unit cell: right-handed vectors spanning a
    /// volume, sites in [0, 1), one orientation per site.
    pub fn check(&self) -> Result<(), CrystalError> {
        let norms: f64 = (0..3).map(|k| self.vectors.column(k).norm()).product();
        let relative = self.vectors.determinant() / norms;
        if !relative.is_finite() || relative < 1e-9 {
            return Err(CrystalError::Degenerate(relative));
        }
        if self.basis.is_empty() || self.orientations.len() != self.basis.len() {
            return Err(CrystalError::Basis {
                sites: self.basis.len(),
                orientations: self.orientations.len(),
            });
        }
        for (i, s) in self.basis.iter().enumerate() {
            if !s.iter().all(|x| (0.0..1.0).contains(x)) {
                return Err(CrystalError::SiteOutside(i, (*s).into()));
            }
        }
        Ok(())
    }
}

/// A crystal to build: a unit cell, how many cells along each vector, and
/// the packing fraction.
#[derive(Debug, Clone, PartialEq)]
pub struct CrystalSpec {
    /// The unit cell.
    pub cell: UnitCell,
    /// Cells along a₁, a₂, a₃.
    pub cells: [usize; 3],
    /// The packing fraction.
    pub packing_fraction: f64,
}

impl CrystalSpec {
    /// The supercell box and the particles on its sites, species filling
    /// the sites in order (`counts[s]` of species s, site by site within a
    /// cell, cell by cell along a₁, then a₂, then a₃).
    pub fn build(
        &self,
        species: &[Species],
        counts: &[usize],
    ) -> Result<(PeriodicBox, Vec<Particle>), CrystalError> {
        self.build_sized(species, counts, None)
    }

    /// [`CrystalSpec::build`] for polydisperse bodies, `sizes` one per
    /// site in order: the packing fraction counts each body at its size,
    /// and the crystal is too dense where the largest body of each species
    /// would touch on its site.
    pub fn build_sized(
        &self,
        species: &[Species],
        counts: &[usize],
        sizes: Option<&[f64]>,
    ) -> Result<(PeriodicBox, Vec<Particle>), CrystalError> {
        let cell = &self.cell;
        cell.check()?;
        let [n1, n2, n3] = self.cells;
        if n1 == 0 || n2 == 0 || n3 == 0 {
            return Err(CrystalError::NoCells(self.cells));
        }
        let phi = self.packing_fraction;
        if !(phi > 0.0 && phi <= 1.0) {
            return Err(CrystalError::PackingFraction(phi));
        }
        let sites = cell.basis.len() * n1 * n2 * n3;
        let particles: usize = counts.iter().sum();
        if particles != sites {
            return Err(CrystalError::Count {
                sites,
                basis: cell.basis.len(),
                cells: self.cells,
                particles,
            });
        }
        let kinds: Vec<u16> = (counts.iter().enumerate())
            .flat_map(|(s, &k)| std::iter::repeat_n(s as u16, k))
            .collect();
        // The volume the bodies fill fixes the scale.
        let size = |i: usize| sizes.map_or(1.0, |f| f[i]);
        let filled: f64 = (kinds.iter().enumerate())
            .map(|(i, &k)| species[k as usize].shape.volume() * size(i).powi(3))
            .sum();
        let det = cell.vectors.determinant() * (n1 * n2 * n3) as f64;
        let scale = (filled / (phi * det)).cbrt();
        let touching = match sizes {
            None => touching_scale(cell, &kinds, species)?,
            Some(sizes) => {
                let at_largest =
                    super::sizes::species_at_largest(species, kinds.iter().copied(), sizes);
                touching_scale(cell, &kinds, &at_largest)?
            }
        };
        if scale <= touching {
            return Err(CrystalError::TooDense {
                asked: phi,
                limit: filled / (det * touching.powi(3)),
            });
        }
        let (rotation, upper) = upright(&(cell.vectors * scale));
        let supercell = upper * Matrix3::from_diagonal(&V3::new(n1 as f64, n2 as f64, n3 as f64));
        let box_ = PeriodicBox::triclinic(
            V3::new(supercell[(0, 0)], supercell[(1, 1)], supercell[(2, 2)]),
            V3::new(
                supercell[(0, 1)] / supercell[(1, 1)],
                supercell[(0, 2)] / supercell[(2, 2)],
                supercell[(1, 2)] / supercell[(2, 2)],
            ),
        )
        .map_err(|_| CrystalError::Degenerate(0.0))?;
        let origin = supercell * V3::repeat(0.5);
        let mut placed = Vec::with_capacity(sites);
        for k in 0..n3 {
            for j in 0..n2 {
                for i in 0..n1 {
                    let at = V3::new(i as f64, j as f64, k as f64);
                    for (b, site) in cell.basis.iter().enumerate() {
                        placed.push(Particle {
                            position: box_.wrap(&(upper * (at + site) - origin)),
                            orientation: rotation * cell.orientations[b],
                            species: kinds[placed.len()],
                        });
                    }
                }
            }
        }
        Ok((box_, placed))
    }

    /// The packing fraction at which the bodies of this crystal touch.
    pub fn densest_packing_fraction(
        &self,
        species: &[Species],
        counts: &[usize],
    ) -> Result<f64, CrystalError> {
        self.cell.check()?;
        let kinds: Vec<u16> = (counts.iter().enumerate())
            .flat_map(|(s, &k)| std::iter::repeat_n(s as u16, k))
            .take(self.cell.basis.len())
            .collect();
        let filled: f64 = kinds
            .iter()
            .map(|&k| species[k as usize].shape.volume())
            .sum();
        let touching = touching_scale(&self.cell, &kinds, species)?;
        Ok(filled / (self.cell.vectors.determinant() * touching.powi(3)))
    }
}

/// The rotation R and upper-triangular U with positive diagonal such that
/// R·A = U (a QR decomposition of A = Rᵀ U with the signs fixed; for a
/// right-handed A, R is a proper rotation).
fn upright(a: &Matrix3<f64>) -> (UnitQuaternion<f64>, Matrix3<f64>) {
    let qr = a.qr();
    let (mut q, mut r) = (qr.q(), qr.r());
    for k in 0..3 {
        if r[(k, k)] < 0.0 {
            r.row_mut(k).neg_mut();
            q.column_mut(k).neg_mut();
        }
    }
    let rotation = nalgebra::Rotation3::from_matrix_unchecked(q.transpose());
    (UnitQuaternion::from_rotation_matrix(&rotation), r)
}

/// The smallest scale of the unit cell at which no two bodies of the
/// crystal overlap (bodies on the sites of `kinds`, one per site, in the
/// lattice frame), by bisection to 1e-13: overlap of convex bodies at fixed
/// orientations is monotone in the scale (their separations scale, and
/// the set of overlapping separations is star-shaped about the origin).
fn touching_scale(
    cell: &UnitCell,
    kinds: &[u16],
    species: &[Species],
) -> Result<f64, CrystalError> {
    let shape = |b: usize| &species[kinds[b] as usize].shape;
    let reach = (0..cell.basis.len())
        .map(|b| shape(b).bounding_radius())
        .fold(0.0, f64::max);
    // Separations are compared through their squares: a reach whose square
    // overflows or vanishes would make every pair seem apart.
    if !(reach * reach).is_normal() {
        return Err(CrystalError::Scale(reach));
    }
    let unit = lattice_box(&cell.vectors)?;
    let overlaps = |scale: f64| -> bool {
        // Lattice translations within twice the largest reach, per axis.
        let span = unit
            .heights()
            .map(|h| (2.0 * reach / (scale * h)).ceil() as i64 + 1);
        for (p, sp) in cell.basis.iter().enumerate() {
            for (q, sq) in cell.basis.iter().enumerate() {
                for i in -span.x..=span.x {
                    for j in -span.y..=span.y {
                        for k in -span.z..=span.z {
                            if p == q && (i, j, k) == (0, 0, 0) {
                                continue;
                            }
                            let m = V3::new(i as f64, j as f64, k as f64);
                            let d = cell.vectors * (m + sq - sp) * scale;
                            let limit = shape(p).bounding_radius() + shape(q).bounding_radius();
                            if d.norm() <= limit
                                && overlap(
                                    shape(p),
                                    shape(q),
                                    &Relative::new(
                                        &d,
                                        &cell.orientations[p],
                                        &cell.orientations[q],
                                    ),
                                )
                            {
                                return true;
                            }
                        }
                    }
                }
            }
        }
        false
    };
    // Start where the lattice's heights are twice the largest reach: the
    // search then looks at a few translations per axis, whatever the
    // bodies' size.
    let start = 2.0 * reach / unit.heights().min();
    let (mut lo, mut hi) = (0.0, start);
    while overlaps(hi) {
        (lo, hi) = (hi, 2.0 * hi);
        if hi > 1e12 * start {
            return Err(CrystalError::Coincident);
        }
    }
    // Bisection to 1e-13; `hi` never overlaps. Bounded, so that bodies
    // whose distances overflow (nothing ever overlaps) end in an error.
    for _ in 0..MAX_BISECTIONS {
        if hi - lo <= 1e-13 * hi {
            return Ok(hi);
        }
        let mid = 0.5 * (lo + hi);
        if overlaps(mid) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Err(CrystalError::Scale(reach))
}

/// Halvings of the touching scale's bracket: from [0, start] to 1e-13
/// relative takes about 45 where the bodies touch near `start`.
const MAX_BISECTIONS: usize = 200;

/// The lattice of `vectors` as a box (for its heights).
fn lattice_box(vectors: &Matrix3<f64>) -> Result<PeriodicBox, CrystalError> {
    let (_, u) = upright(vectors);
    PeriodicBox::triclinic(
        V3::new(u[(0, 0)], u[(1, 1)], u[(2, 2)]),
        V3::new(
            u[(0, 1)] / u[(1, 1)],
            u[(0, 2)] / u[(2, 2)],
            u[(1, 2)] / u[(2, 2)],
        ),
    )
    .map_err(|_| CrystalError::Degenerate(0.0))
}

/// The crystal as a checked system.
pub fn crystal(
    spec: &CrystalSpec,
    species: Vec<Species>,
    counts: &[usize],
) -> Result<System, CrystalError> {
    let (box_, particles) = spec.build(&species, counts)?;
    Ok(System::new(box_, species, particles)?)
}

/// [`crystal`] of polydisperse bodies (see [`CrystalSpec::build_sized`]).
pub fn crystal_sized(
    spec: &CrystalSpec,
    species: Vec<Species>,
    counts: &[usize],
    sizes: Vec<f64>,
) -> Result<System, CrystalError> {
    let (box_, particles) = spec.build_sized(&species, counts, Some(&sizes))?;
    Ok(System::with_sizes(box_, species, particles, sizes)?)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn one(shape: &str, count: usize) -> (Vec<Species>, Vec<usize>) {
        let species = vec![Species {
            name: "s".into(),
            shape: shape.parse().unwrap(),
            rotation: true,
        }];
        (species, vec![count])
    }

    /// The touching search costs the same for bodies of any size: spheres
    /// of radius 10⁵ and 10⁻⁵ on fcc touch at π/√18 (a search that began
    /// at unit scale looked at (4·10⁵)³ translations for the large ones).
    #[test]
    fn touching_is_found_for_bodies_of_any_size() {
        let pi = std::f64::consts::PI;
        for radius in [1e5, 1e-5] {
            let (species, counts) = one(&format!("Sphere(radius: {radius})"), 4 * 27);
            let spec = CrystalSpec {
                cell: UnitCell::fcc(),
                cells: [3, 3, 3],
                packing_fraction: 0.5,
            };
            let limit = spec.densest_packing_fraction(&species, &counts).unwrap();
            assert!(
                (limit - pi / 18f64.sqrt()).abs() < 1e-10,
                "{radius}: {limit}"
            );
        }
    }

    /// The close-packed lattices of spheres touch at π/√18, bcc at
    /// π√3/8, simple cubic at π/6, the known values to 1e-10; a start just
    /// below is built overlap-free, one just above is refused naming the
    /// limit.
    #[test]
    fn sphere_lattices_touch_at_their_known_packing_fractions() {
        let pi = std::f64::consts::PI;
        for (cell, per_cell, known) in [
            (UnitCell::fcc(), 4, pi / 18f64.sqrt()),
            (UnitCell::hcp(), 4, pi / 18f64.sqrt()),
            (UnitCell::bcc(), 2, pi * 3f64.sqrt() / 8.0),
            (UnitCell::simple_cubic(), 1, pi / 6.0),
        ] {
            let (species, counts) = one("Sphere(radius: 0.5)", per_cell * 27);
            let spec = CrystalSpec {
                cell,
                cells: [3, 3, 3],
                packing_fraction: known * (1.0 - 1e-6),
            };
            let limit = spec.densest_packing_fraction(&species, &counts).unwrap();
            assert!((limit - known).abs() < 1e-10, "{limit} vs {known}");
            let system = crystal(&spec, species.clone(), &counts).unwrap();
            assert_eq!(system.first_overlap_all_pairs(), None);
            let phi = counts[0] as f64 * species[0].shape.volume() / system.periodic_box().volume();
            assert!((phi - spec.packing_fraction).abs() < 1e-12);
            let dense = CrystalSpec {
                packing_fraction: known * (1.0 + 1e-6),
                ..spec
            };
            assert!(matches!(
                crystal(&dense, species, &counts),
                Err(CrystalError::TooDense { .. })
            ));
        }
    }

    /// The primitive rhombohedral cell of fcc makes a tilted box holding
    /// the same crystal: every sphere has 12 neighbours at the same
    /// distance as in the conventional cubic cell.
    #[test]
    fn primitive_fcc_is_the_same_crystal_in_a_tilted_box() {
        let primitive = UnitCell {
            vectors: Matrix3::new(0.0, 0.5, 0.5, 0.5, 0.0, 0.5, 0.5, 0.5, 0.0),
            basis: vec![V3::zeros()],
            orientations: vec![UnitQuaternion::identity()],
        };
        let phi = 0.6;
        let mut shells = Vec::new();
        for (cell, cells, n) in [
            (UnitCell::fcc(), [4, 4, 4], 256),
            (primitive, [6, 6, 6], 216),
        ] {
            let (species, counts) = one("Sphere(radius: 0.5)", n);
            let spec = CrystalSpec {
                cell,
                cells,
                packing_fraction: phi,
            };
            let system = crystal(&spec, species, &counts).unwrap();
            let box_ = system.periodic_box();
            let positions: Vec<V3> = system.particles().iter().map(|p| p.position).collect();
            let mut nearest = Vec::new();
            for (i, r) in positions.iter().enumerate() {
                let mut d: Vec<f64> = (0..positions.len())
                    .filter(|&j| j != i)
                    .map(|j| box_.minimum_image(&(positions[j] - r)).norm())
                    .collect();
                d.sort_by(f64::total_cmp);
                assert!(
                    (d[11] - d[0]).abs() < 1e-9 && d[12] > d[0] * 1.2,
                    "{:?}",
                    &d[..13]
                );
                nearest.push(d[0]);
            }
            shells.push((nearest[0], box_.is_tilted()));
        }
        assert!((shells[0].0 - shells[1].0).abs() < 1e-9, "{shells:?}");
        assert_eq!((shells[0].1, shells[1].1), (false, true));
    }

    /// Ellipsoids on the stretched fcc and cuboids stacked fill their
    /// known fractions (π/√18 and 1).
    #[test]
    fn densest_lattices_of_ellipsoids_and_cuboids() {
        for (shape, known) in [
            (
                "Ellipsoid(a: 1.5, b: 0.5, c: 0.8)",
                std::f64::consts::PI / 18f64.sqrt(),
            ),
            ("Cuboid(a: 1.0, b: 0.5, c: 0.3)", 1.0),
        ] {
            let (species, _) = one(shape, 1);
            let cell = UnitCell::densest(&species[0].shape).unwrap();
            let counts = vec![cell.basis.len() * 4 * 8 * 12];
            let spec = CrystalSpec {
                cell,
                cells: [4, 8, 12],
                packing_fraction: 0.5,
            };
            let limit = spec.densest_packing_fraction(&species, &counts).unwrap();
            assert!((limit - known).abs() < 1e-9, "{shape}: {limit}");
            let near = CrystalSpec {
                packing_fraction: known * (1.0 - 1e-6),
                ..spec
            };
            let system = crystal(&near, species, &counts).unwrap();
            assert_eq!(system.first_overlap_all_pairs(), None);
        }
    }

    /// Bad unit cells and counts are refused, each with its own error.
    #[test]
    fn bad_cells_are_refused() {
        let (species, counts) = one("Sphere(radius: 0.5)", 4 * 27);
        let spec = |cell: UnitCell, cells: [usize; 3], phi: f64| CrystalSpec {
            cell,
            cells,
            packing_fraction: phi,
        };
        let mut flat = UnitCell::fcc();
        flat.vectors.set_column(2, &V3::new(1.0, 1.0, 0.0));
        let mut left = UnitCell::fcc();
        left.vectors.set_column(2, &V3::new(0.0, 0.0, -1.0));
        let mut twice = UnitCell::fcc();
        twice.basis[1] = twice.basis[0];
        let mut outside = UnitCell::fcc();
        outside.basis[1] = V3::new(1.0, 0.0, 0.0);
        let cases = [
            (spec(flat, [3; 3], 0.5), "Degenerate"),
            (spec(left, [3; 3], 0.5), "Degenerate"),
            (spec(twice, [3; 3], 0.5), "Coincident"),
            (spec(outside, [3; 3], 0.5), "SiteOutside"),
            (spec(UnitCell::fcc(), [3, 0, 3], 0.5), "NoCells"),
            (spec(UnitCell::fcc(), [3, 3, 2], 0.5), "Count"),
            (spec(UnitCell::fcc(), [3; 3], f64::NAN), "PackingFraction"),
            (spec(UnitCell::fcc(), [3; 3], 0.75), "TooDense"),
        ];
        for (case, expected) in cases {
            let got = crystal(&case, species.clone(), &counts).unwrap_err();
            assert!(
                format!("{got:?}").starts_with(expected),
                "{got:?} for {expected}"
            );
        }
        // Sizes whose squares overflow or vanish: every pair would seem
        // apart at any scale, and the search would never end.
        for radius in ["1e300", "1e-300"] {
            let (huge, counts) = one(&format!("Sphere(radius: {radius})"), 4 * 27);
            let got = crystal(&spec(UnitCell::fcc(), [3; 3], 0.5), huge, &counts);
            assert!(matches!(got, Err(CrystalError::Scale(_))), "{got:?}");
        }
        let (small, counts) = one("Sphere(radius: 0.5)", 4);
        let thin = spec(UnitCell::fcc(), [1, 1, 1], 0.5);
        assert!(matches!(
            crystal(&thin, small, &counts),
            Err(CrystalError::System(StateError::BoxTooSmall { .. }))
        ));
    }
}
