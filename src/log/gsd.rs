//! GSD export (`hardbody export LOG --gsd OUT.gsd`): the frames of a log
//! in HOOMD's schema, for OVITO, freud and HOOMD-blue. Frame 0 carries
//! `particles/types` and `particles/type_shapes` (spheres as `Sphere`,
//! ellipsoids as `Ellipsoid`, cuboids as `ConvexPolyhedron`,
//! superellipsoids as `Mesh`), which GSD readers take as the default for
//! later frames. Orientations are written w, x, y, z (GSD's order, the same
//! as `/state`). `configuration/step` is the frame's log time in
//! milliseconds: the sweep in Monte Carlo stages, thousandths of simulated
//! time in dynamics.

use std::path::Path;

use hoomd_gsd::file_layer::GsdFile;

use super::view::superellipsoid_mesh;
use super::{LogError, StateRecord};
use crate::geometry::Shape;

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
        Shape::Superellipsoid(_) => {
            let (points, indices) = superellipsoid_mesh(shape);
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

/// Zero-padded bytes of `text` in a row of `N`.
fn row<const N: usize>(text: &str) -> Result<[u8; N], String> {
    let bytes = text.as_bytes();
    if bytes.len() >= N {
        return Err(format!("{} bytes do not fit a GSD row of {N}", bytes.len()));
    }
    Ok(std::array::from_fn(|i| bytes.get(i).copied().unwrap_or(0)))
}

/// Writes `frames` (log time, state) to `out` (via `<out>.partial`,
/// renamed when complete); returns the number of frames written.
pub fn export(frames: &[(u64, StateRecord)], out: &Path) -> Result<usize, LogError> {
    let partial = super::partial_path(out);
    let fail = |message: String| LogError::Content {
        path: out.to_path_buf(),
        message,
    };
    let first = &frames
        .first()
        .ok_or_else(|| fail("the log has no frames to export".into()))?
        .1;
    let application = format!("hardbody {}", env!("CARGO_PKG_VERSION"));
    let mut gsd = GsdFile::create(&partial, &application, "hoomd", (1, 4))
        .map_err(|e| fail(e.to_string()))?;
    let names: Vec<[u8; NAME_BYTES]> = first
        .species
        .iter()
        .map(|s| row(&s.name))
        .collect::<Result<_, _>>()
        .map_err(|e| fail(format!("species name: {e}")))?;
    let shapes: Vec<[u8; SHAPE_BYTES]> = first
        .species
        .iter()
        .map(|s| row(&type_shape(&s.shape)))
        .collect::<Result<_, _>>()
        .map_err(|e| fail(format!("type shape: {e}")))?;
    for (k, (log_time, state)) in frames.iter().enumerate() {
        if state.species != first.species {
            return Err(fail(format!("frame {k} has other species than frame 0")));
        }
        let w = |e: hoomd_gsd::file_layer::WriteError| fail(format!("frame {k}: {e}"));
        let [lx, ly, lz] = state.box_lengths.map(|l| l as f32);
        gsd.write_scalars("configuration/step", [log_time / 1_000_000])
            .map_err(w)?;
        gsd.write_scalars("configuration/box", [lx, ly, lz, 0.0, 0.0, 0.0])
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
        if k == 0 {
            gsd.write_arrays("particles/types", names.iter().copied())
                .map_err(w)?;
            gsd.write_arrays("particles/type_shapes", shapes.iter().copied())
                .map_err(w)?;
        }
        gsd.end_frame()
            .map_err(|e| fail(format!("frame {k}: {e}")))?;
    }
    gsd.sync_all().map_err(|e| fail(e.to_string()))?;
    drop(gsd);
    std::fs::rename(&partial, out).map_err(|source| LogError::Io {
        path: out.to_path_buf(),
        source,
    })?;
    Ok(frames.len())
}
