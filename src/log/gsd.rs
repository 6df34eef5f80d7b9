//! GSD export (`hardbody export LOG --gsd OUT.gsd`): the frames of a log
//! in HOOMD's schema, for OVITO, freud and HOOMD-blue. Frame 0 carries
//! `particles/types` and `particles/type_shapes` (spheres as `Sphere`,
//! ellipsoids as `Ellipsoid`, cuboids as `ConvexPolyhedron`,
//! superellipsoids as `Mesh`), which GSD readers take as the default for
//! later frames. Orientations are written w, x, y, z (GSD's order, the same
//! as `/state`).
//!
//! Every frame also carries what the dynamics knows of each body: its mass,
//! the principal moments it turns with (zero for bodies that do not turn,
//! HOOMD's convention), its bounding diameter and, in dynamics frames, its
//! angular momentum as HOOMD's quaternion 2 q ⊗ (0, L_body). HOOMD's
//! `configuration/step` is the frame's log time in ns (README, "Logs");
//! the exact stage, sweep and simulated time, the packing fraction and the
//! `/stats` pressure at the frame are under `log/hardbody/`.

use std::path::Path;

use hoomd_gsd::file_layer::GsdFile;

use nalgebra::{Quaternion, UnitQuaternion, Vector3};

use super::read::LogContents;
use super::view::body_mesh;
use super::{LogError, StateRecord, Stats};
use crate::edmd::dynamics::top_moments;
use crate::geometry::Shape;
use crate::scene::{Scene, Stage, ValidScene};

/// Bytes per row of `particles/type_shapes` (JSON, zero-padded): room for
/// the largest superellipsoid mesh.
const SHAPE_BYTES: usize = 32768;
/// Bytes per row of `particles/types`.
const NAME_BYTES: usize = 64;

/// The `type_shapes` JSON of a shape (HOOMD's shape specification).
pub fn type_shape(shape: &Shape) -> String {
    match shape {
        Shape::Sphere(s) => format!(r#"{{"type": "Sphere", "diameter": {}}}"#, 2.0 * s.radius()),
        Shape::Ellipsoid(e) => {
            let a = e.semi_axes();
            format!(
                r#"{{"type": "Ellipsoid", "a": {}, "b": {}, "c": {}}}"#,
                a.x, a.y, a.z
            )
        }
        Shape::Cuboid(c) => {
            let h = c.half_extents();
            let vertices: Vec<String> = (0..8)
                .map(|i| {
                    let s = |bit: usize, v: f64| if i & bit == 0 { -v } else { v };
                    format!("[{}, {}, {}]", s(1, h.x), s(2, h.y), s(4, h.z))
                })
                .collect();
            format!(
                r#"{{"type": "ConvexPolyhedron", "rounding_radius": 0, "vertices": [{}]}}"#,
                vertices.join(", ")
            )
        }
        // A segment swept by a sphere: HOOMD's rounded polyhedron of two
        // vertices.
        Shape::Spherocylinder(s) => format!(
            r#"{{"type": "ConvexPolyhedron", "rounding_radius": {}, "vertices": [[0, 0, {}], [0, 0, {}]]}}"#,
            s.radius(),
            -s.half_length(),
            s.half_length()
        ),
        Shape::ConvexPolyhedron(p) => {
            let vertices: Vec<String> = (p.corners())
                .map(|v| format!("[{}, {}, {}]", v.x, v.y, v.z))
                .collect();
            // HOOMD's ConvexSpheropolyhedron is the same body as a
            // ConvexPolyhedron with its rounding radius.
            format!(
                r#"{{"type": "ConvexPolyhedron", "rounding_radius": {}, "vertices": [{}]}}"#,
                p.rounding(),
                vertices.join(", ")
            )
        }
        Shape::Superellipsoid(_) => {
            let (points, indices) = body_mesh(shape);
            let vertices: Vec<String> = points
                .iter()
                .map(|p| format!("[{:.6}, {:.6}, {:.6}]", p.x, p.y, p.z))
                .collect();
            let faces: Vec<String> = indices
                .chunks(3)
                .map(|f| format!("[{}, {}, {}]", f[0], f[1], f[2]))
                .collect();
            format!(
                r#"{{"type": "Mesh", "vertices": [{}], "indices": [{}]}}"#,
                vertices.join(", "),
                faces.join(", ")
            )
        }
    }
}

/// A text longer than a GSD row holds (with its terminating zero).
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
#[error("{bytes} bytes do not fit a GSD row of {row}")]
struct RowTooLong {
    bytes: usize,
    row: usize,
}

/// Zero-padded bytes of `text` in a row of `N`.
fn row<const N: usize>(text: &str) -> Result<[u8; N], RowTooLong> {
    let bytes = text.as_bytes();
    if bytes.len() >= N {
        return Err(RowTooLong {
            bytes: bytes.len(),
            row: N,
        });
    }
    Ok(std::array::from_fn(|i| bytes.get(i).copied().unwrap_or(0)))
}

/// What the export knows of a body of each species in a frame.
struct Body {
    mass: f32,
    moments: [f32; 3],
    diameter: f32,
}

/// The bodies of `state`'s species in its stage of `scene` (masses 1 and
/// spherical tops where the log holds no scene).
fn bodies(state: &StateRecord, scene: Option<&ValidScene>) -> Vec<Body> {
    let true_inertia = matches!(
        scene.and_then(|s| s.stages.get(state.stage_index)),
        Some(Stage::Dynamics {
            true_inertia: true,
            ..
        })
    );
    state
        .species
        .iter()
        .enumerate()
        .map(|(k, species)| {
            let mass = scene.and_then(|s| s.species.get(k)).map_or(1.0, |s| s.mass);
            let turns = species.rotation && !species.shape.is_sphere();
            let moments: [f64; 3] = top_moments(&species.shape, mass, true_inertia).into();
            Body {
                mass: mass as f32,
                moments: if turns {
                    moments.map(|x| x as f32)
                } else {
                    [0.0; 3]
                },
                diameter: (2.0 * species.shape.bounding_radius()) as f32,
            }
        })
        .collect()
}

/// HOOMD's angular momentum quaternion 2 q ⊗ (0, L_body), with L_body =
/// I ω_body.
fn angular_momentum(orientation: &[f64; 4], omega_lab: &[f64; 3], moments: &[f32; 3]) -> [f32; 4] {
    let [w, x, y, z] = *orientation;
    let q = UnitQuaternion::new_unchecked(Quaternion::new(w, x, y, z));
    let omega_body = q.inverse_transform_vector(&Vector3::from(*omega_lab));
    let l_body = omega_body.component_mul(&Vector3::from(moments.map(f64::from)));
    let p = q.quaternion() * Quaternion::from_imag(l_body) * 2.0;
    [p.w, p.i, p.j, p.k].map(|v| v as f32)
}

/// The `/stats` pressure of `state`'s stage at `log_time`, if a message
/// was written there.
fn pressure_at(stats: &[(u64, Stats)], log_time: u64, stage_index: usize) -> f64 {
    stats
        .iter()
        .find(|(t, s)| *t == log_time && s.stage_index == stage_index)
        .and_then(|(_, s)| s.pressure)
        .unwrap_or(f64::NAN)
}

/// Writes the frames of `contents` to `out` (via `<out>.partial`, renamed
/// when complete); returns the number of frames written. On failure no
/// partial file is left behind.
pub fn export(contents: &LogContents, out: &Path) -> Result<usize, LogError> {
    let partial = super::partial_path(out);
    let written = write_gsd(contents, out, &partial);
    if written.is_err() && !super::file::is_link(&partial) {
        let _ = std::fs::remove_file(&partial);
    }
    written
}

/// A GSD writer's error on `out`, in `context`: the I/O error at its root
/// where there is one (so a full disk is named, and told from bad data).
fn gsd_error(out: &Path, context: &str, e: &(dyn std::error::Error + 'static)) -> LogError {
    match super::io_cause(e) {
        Some(io) => LogError::Io {
            path: out.to_path_buf(),
            source: std::io::Error::new(io.kind(), io.to_string()),
        },
        None => LogError::Content {
            path: out.to_path_buf(),
            message: format!("{context}{e}"),
        },
    }
}

fn write_gsd(contents: &LogContents, out: &Path, partial: &Path) -> Result<usize, LogError> {
    let frames = &contents.states;
    let scene = contents
        .metadata
        .get("scene_resolved")
        .and_then(|text| Scene::parse(text).ok());
    let fail = |message: String| LogError::Content {
        path: out.to_path_buf(),
        message,
    };
    let first = &frames
        .first()
        .ok_or_else(|| fail("the log has no frames to export".into()))?
        .1;
    let application = format!("hardbody {}", env!("CARGO_PKG_VERSION"));
    // Made here first: a link planted at the partial path is refused, not
    // followed by the GSD writer.
    drop(super::file::create_fresh(partial)?);
    let mut gsd = GsdFile::create(partial, &application, "hoomd", (1, 4))
        .map_err(|e| gsd_error(out, "", &e))?;
    let names: Vec<[u8; NAME_BYTES]> = first
        .species
        .iter()
        .map(|s| row(&s.name))
        .collect::<Result<_, _>>()
        .map_err(|e| fail(format!("species name: {e}")))?;
    let type_shapes = |state: &StateRecord| -> Result<Vec<[u8; SHAPE_BYTES]>, LogError> {
        state
            .species
            .iter()
            .map(|s| row(&type_shape(&s.shape)))
            .collect::<Result<_, _>>()
            .map_err(|e| fail(format!("type shape: {e}")))
    };
    let shapes = type_shapes(first)?;
    for (k, (log_time, state)) in frames.iter().enumerate() {
        // The same species throughout; their sizes may change (a jam
        // stage grows them), and a frame whose shapes differ from frame
        // 0's carries its own (GSD takes a chunk missing from a frame
        // from frame 0).
        let kinds_differ = state.species.len() != first.species.len()
            || state.species.iter().zip(&first.species).any(|(a, b)| {
                a.name != b.name || a.rotation != b.rotation || a.shape.kind() != b.shape.kind()
            });
        if kinds_differ {
            return Err(fail(format!("frame {k} has other species than frame 0")));
        }
        let own_shapes = (k > 0 && state.species != first.species)
            .then(|| type_shapes(state))
            .transpose()?;
        let context = format!("frame {k}: ");
        let w = |e: hoomd_gsd::file_layer::WriteError| gsd_error(out, &context, &e);
        let [lx, ly, lz] = state.box_lengths.map(|l| l as f32);
        let [xy, xz, yz] = state.tilts.map(|t| t as f32);
        gsd.write_scalars("configuration/step", [*log_time])
            .map_err(w)?;
        gsd.write_scalars("configuration/box", [lx, ly, lz, xy, xz, yz])
            .map_err(w)?;
        gsd.write_scalars("particles/N", [state.positions.len() as u32])
            .map_err(w)?;
        gsd.write_arrays(
            "particles/position",
            state.positions.iter().map(|p| p.map(|x| x as f32)),
        )
        .map_err(w)?;
        gsd.write_arrays(
            "particles/orientation",
            state.orientations.iter().map(|q| q.map(|x| x as f32)),
        )
        .map_err(w)?;
        gsd.write_scalars(
            "particles/typeid",
            state.species_of.iter().map(|&s| s as u32),
        )
        .map_err(w)?;
        if let Some(v) = &state.velocities {
            gsd.write_arrays("particles/velocity", v.iter().map(|p| p.map(|x| x as f32)))
                .map_err(w)?;
        }
        let kinds = bodies(state, scene.as_ref());
        let of = |k: &u16| &kinds[*k as usize];
        gsd.write_scalars(
            "particles/mass",
            state.species_of.iter().map(|k| of(k).mass),
        )
        .map_err(w)?;
        gsd.write_scalars(
            "particles/diameter",
            (state.species_of.iter().enumerate())
                .map(|(i, k)| of(k).diameter * state.size_of(i) as f32),
        )
        .map_err(w)?;
        gsd.write_arrays(
            "particles/moment_inertia",
            // A body at size f: the species' mass, its moments f² times.
            (state.species_of.iter().enumerate()).map(|(i, k)| {
                let f2 = state.size_of(i).powi(2) as f32;
                of(k).moments.map(|m| m * f2)
            }),
        )
        .map_err(w)?;
        if let Some(omega) = &state.angular_velocities {
            gsd.write_arrays(
                "particles/angmom",
                state
                    .orientations
                    .iter()
                    .zip(omega)
                    .zip(&state.species_of)
                    .map(|((q, o), k)| angular_momentum(q, o, &of(k).moments)),
            )
            .map_err(w)?;
        }
        let volume: f64 = state.box_lengths.iter().product();
        let packing_fraction = (state.species_of.iter().enumerate())
            .map(|(i, &k)| state.species[k as usize].shape.volume() * state.size_of(i).powi(3))
            .sum::<f64>()
            / volume;
        for (name, value) in [
            ("log/hardbody/stage_index", state.stage_index as f64),
            (
                "log/hardbody/sweep",
                state.sweep.map_or(f64::NAN, |s| s as f64),
            ),
            ("log/hardbody/time", state.time.unwrap_or(f64::NAN)),
            ("log/hardbody/packing_fraction", packing_fraction),
            (
                "log/hardbody/pressure",
                pressure_at(&contents.stats, *log_time, state.stage_index),
            ),
        ] {
            gsd.write_scalars(name, [value]).map_err(w)?;
        }
        if k == 0 {
            gsd.write_arrays("particles/types", names.iter().copied())
                .map_err(w)?;
            gsd.write_arrays("particles/type_shapes", shapes.iter().copied())
                .map_err(w)?;
        } else if let Some(own) = &own_shapes {
            gsd.write_arrays("particles/type_shapes", own.iter().copied())
                .map_err(w)?;
        }
        gsd.end_frame().map_err(|e| gsd_error(out, &context, &e))?;
    }
    gsd.sync_all().map_err(|e| gsd_error(out, "", &e))?;
    drop(gsd);
    std::fs::rename(partial, out).map_err(|source| LogError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    Ok(frames.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A row holds its text and a terminating zero: 63 bytes fit a row of
    /// 64, zero-padded; 64 are refused, naming both sizes.
    #[test]
    fn a_row_holds_its_text_and_a_zero() {
        let fits: [u8; NAME_BYTES] = row(&"a".repeat(63)).unwrap();
        assert_eq!((fits[62], fits[63]), (b'a', 0));
        let err = row::<NAME_BYTES>(&"a".repeat(64)).unwrap_err();
        assert_eq!(err, RowTooLong { bytes: 64, row: 64 });
        assert_eq!(err.to_string(), "64 bytes do not fit a GSD row of 64");
    }

    /// A spheropolyhedron is HOOMD's ConvexPolyhedron with its rounding
    /// radius, the vertices those of its core; a polyhedron's radius is 0.
    #[test]
    fn a_spheropolyhedron_carries_its_rounding_radius() {
        let corners = "[(1.0, 1.0, 1.0), (1.0, -1.0, -1.0), (-1.0, 1.0, -1.0), (-1.0, -1.0, 1.0)]";
        for (text, radius) in [
            (
                format!("Spheropolyhedron(vertices: {corners}, radius: 0.25)"),
                0.25,
            ),
            (format!("ConvexPolyhedron(vertices: {corners})"), 0.0),
        ] {
            let shape: Shape = text.parse().unwrap();
            let json: serde_json::Value = serde_json::from_str(&type_shape(&shape)).unwrap();
            assert_eq!(json["type"], "ConvexPolyhedron", "{json}");
            assert_eq!(json["rounding_radius"].as_f64(), Some(radius), "{json}");
            let vertices = json["vertices"].as_array().unwrap();
            assert_eq!(vertices.len(), 4);
            assert_eq!(vertices[0][0].as_f64().map(f64::abs), Some(1.0));
        }
    }
}
