//! Where a scene's bodies live: the box (`(Lx, Ly, Lz)` or
//! `Triclinic(lengths: (Lx, Ly, Lz), tilts: (xy, xz, yz))`) and the
//! lattices of a `Crystal` start.

use nalgebra::{Matrix3, Quaternion, UnitQuaternion, Vector3};
use serde::de::{self, MapAccess, SeqAccess, Visitor};
use serde::ser::SerializeStruct;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use crate::geometry::Shape;
use crate::state::crystal::{CrystalError, UnitCell};

/// A box: edges, and tilt factors (all zero for an orthorhombic box).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BoxSpec {
    /// Edges (Lx, Ly, Lz).
    pub lengths: (f64, f64, f64),
    /// Tilt factors (xy, xz, yz).
    pub tilts: (f64, f64, f64),
}

impl BoxSpec {
    /// An orthorhombic box.
    pub fn edges(x: f64, y: f64, z: f64) -> Self {
        Self {
            lengths: (x, y, z),
            tilts: (0.0, 0.0, 0.0),
        }
    }

    /// Whether any tilt is not zero.
    pub fn is_tilted(&self) -> bool {
        self.tilts != (0.0, 0.0, 0.0)
    }
}

impl Serialize for BoxSpec {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        if self.is_tilted() {
            let mut t = s.serialize_struct("Triclinic", 2)?;
            t.serialize_field("lengths", &self.lengths)?;
            t.serialize_field("tilts", &self.tilts)?;
            t.end()
        } else {
            self.lengths.serialize(s)
        }
    }
}

impl<'de> Deserialize<'de> for BoxSpec {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_any(BoxVisitor)
    }
}

struct BoxVisitor;

impl<'de> Visitor<'de> for BoxVisitor {
    type Value = BoxSpec;

    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str(
            "box edges (Lx, Ly, Lz) or Triclinic(lengths: (Lx, Ly, Lz), tilts: (xy, xz, yz))",
        )
    }

    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<BoxSpec, A::Error> {
        let mut edge = |k: usize| -> Result<f64, A::Error> {
            seq.next_element()?
                .ok_or_else(|| de::Error::invalid_length(k, &"three box edges"))
        };
        let (x, y, z) = (edge(0)?, edge(1)?, edge(2)?);
        if seq.next_element::<de::IgnoredAny>()?.is_some() {
            return Err(de::Error::invalid_length(4, &"three box edges"));
        }
        Ok(BoxSpec::edges(x, y, z))
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<BoxSpec, A::Error> {
        let (mut lengths, mut tilts) = (None, None);
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "lengths" => lengths = Some(map.next_value()?),
                "tilts" => tilts = Some(map.next_value()?),
                other => return Err(de::Error::unknown_field(other, &["lengths", "tilts"])),
            }
        }
        Ok(BoxSpec {
            lengths: lengths.ok_or_else(|| de::Error::missing_field("lengths"))?,
            tilts: tilts.unwrap_or((0.0, 0.0, 0.0)),
        })
    }
}

/// The lattice of a `Crystal` start.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub enum Lattice {
    /// Face-centred cubic, the conventional cubic cell (4 sites).
    Fcc,
    /// Body-centred cubic, the conventional cubic cell (2 sites).
    Bcc,
    /// Hexagonal close packing, its orthorhombic cell (4 sites).
    Hcp,
    /// One site per cubic cell.
    SimpleCubic,
    /// The densest known lattice packing of the (first) species' shape.
    Densest,
    /// Any lattice.
    Custom {
        /// The three lattice vectors, right-handed.
        vectors: Vec<(f64, f64, f64)>,
        /// Sites in fractional coordinates, in [0, 1).
        basis: Vec<(f64, f64, f64)>,
        /// The orientation of the body on each site as a quaternion
        /// (w, x, y, z), normalised; none: every body aligned.
        #[serde(default)]
        orientations: Vec<(f64, f64, f64, f64)>,
    },
}

impl Lattice {
    /// The unit cell, for bodies of `shape` (the shape matters to
    /// `Densest` only).
    pub fn unit_cell(&self, shape: &Shape) -> Result<UnitCell, CrystalError> {
        match self {
            Lattice::Fcc => Ok(UnitCell::fcc()),
            Lattice::Bcc => Ok(UnitCell::bcc()),
            Lattice::Hcp => Ok(UnitCell::hcp()),
            Lattice::SimpleCubic => Ok(UnitCell::simple_cubic()),
            Lattice::Densest => UnitCell::densest(shape),
            Lattice::Custom {
                vectors,
                basis,
                orientations,
            } => {
                if vectors.len() != 3 {
                    return Err(CrystalError::Vectors(vectors.len()));
                }
                let column = |v: &(f64, f64, f64)| Vector3::new(v.0, v.1, v.2);
                let orientations = if orientations.is_empty() {
                    vec![UnitQuaternion::identity(); basis.len()]
                } else {
                    let mut unit = Vec::with_capacity(orientations.len());
                    for (i, &(w, x, y, z)) in orientations.iter().enumerate() {
                        let q = Quaternion::new(w, x, y, z);
                        let norm = q.norm();
                        if !norm.is_finite() || norm < 1e-12 {
                            return Err(CrystalError::Orientation(i));
                        }
                        unit.push(UnitQuaternion::from_quaternion(q));
                    }
                    unit
                };
                Ok(UnitCell {
                    vectors: Matrix3::from_columns(&[
                        column(&vectors[0]),
                        column(&vectors[1]),
                        column(&vectors[2]),
                    ]),
                    basis: basis.iter().map(column).collect(),
                    orientations,
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Deserialize, Serialize, PartialEq)]
    struct Holder {
        #[serde(rename = "box")]
        box_: BoxSpec,
    }

    /// Both spellings read, and each writes back as itself.
    #[test]
    fn boxes_read_and_write_in_both_spellings() {
        for (text, expected) in [
            ("(box: (4.0, 5.0, 6.0))", BoxSpec::edges(4.0, 5.0, 6.0)),
            (
                "(box: Triclinic(lengths: (4.0, 5.0, 6.0), tilts: (0.5, 0.0, -0.25)))",
                BoxSpec {
                    lengths: (4.0, 5.0, 6.0),
                    tilts: (0.5, 0.0, -0.25),
                },
            ),
        ] {
            let read: Holder = ron::from_str(text).unwrap();
            assert_eq!(read.box_, expected, "{text}");
            let written = ron::ser::to_string_pretty(
                &read,
                ron::ser::PrettyConfig::default().struct_names(true),
            )
            .unwrap();
            let again: Holder = ron::from_str(&written).unwrap();
            assert_eq!(again, read, "{written}");
        }
        for bad in [
            "(box: (4.0, 5.0))",
            "(box: (4.0, 5.0, 6.0, 7.0))",
            "(box: Triclinic(lengths: (4.0, 5.0, 6.0), tilt: (0.0, 0.0, 0.0)))",
            "(box: Triclinic(tilts: (0.0, 0.0, 0.0)))",
        ] {
            assert!(ron::from_str::<Holder>(bad).is_err(), "{bad}");
        }
    }
}
