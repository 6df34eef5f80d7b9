//! The JSON schemas of the log's `/failure`, `/stats` and `/state`
//! channels, as the MCAP file names them (readers such as Foxglove show
//! the fields by them).

/// `/failure`.
pub(super) const FAILURE_SCHEMA: &str = r#"{
  "type": "object",
  "description": "why a hardbody run failed; dump: the dynamics' stored state (per body its own time, pose, velocities), to replay the failure",
  "properties": {
    "stage_index": {"type": "integer"},
    "message": {"type": "string"},
    "dump": {"type": ["object", "null"]}
  }
}"#;

/// `/stats`.
pub(super) const STATS_SCHEMA: &str = r#"{
  "type": "object",
  "properties": {
    "stage": {"type": "string"},
    "stage_index": {"type": "integer"},
    "sweep": {"type": ["integer", "null"]},
    "time": {"type": ["number", "null"]},
    "packing_fraction": {"type": "number"},
    "pressure": {"type": ["number", "null"]},
    "pressure_tensor": {"type": "array", "items": {"type": "number"}, "description": "betaP_ab as (xx, xy, xz, yy, yz, zz) over the interval: dynamics in a periodic box from the collision virial; Monte Carlo stages asked for it from the scale distribution; absent otherwise"},
    "box": {"type": "array", "items": {"type": "number"}},
    "tilts": {"type": "array", "items": {"type": "number"}, "description": "box tilt factors (xy, xz, yz); absent when all are zero"},
    "acceptance_translate": {"type": ["number", "null"]},
    "acceptance_rotate": {"type": ["number", "null"]},
    "acceptance_volume": {"type": ["number", "null"]},
    "acceptance_shear": {"type": "number", "description": "NPT with triclinic box moves; absent otherwise"},
    "acceptance_swap": {"type": "number", "description": "size swaps of Monte Carlo stages with swaps; absent otherwise"},
    "collisions": {"type": ["integer", "null"]},
    "temperature": {"type": ["number", "null"]},
    "nematic_order": {"type": ["number", "null"]},
    "msd": {"type": ["number", "null"]},
    "c2": {"type": ["number", "null"]},
    "solver": {"type": ["object", "null"], "description": "dynamics: distances, iterations, fallbacks, iteration_caps, grazing_refinements, roundoff_contacts since the stage began"},
    "overlap_strains": {"type": ["object", "null"], "description": "Monte Carlo, over the interval: overlap tests GJK left undecided, settled_by_distance or taken_as_overlap"}
  }
}"#;

/// `/state`.
pub(super) const STATE_SCHEMA: &str = r#"{
  "type": "object",
  "description": "hardbody full-precision state; orientations are unit quaternions body->lab as [w, x, y, z]",
  "properties": {
    "stage_index": {"type": "integer"},
    "stage": {"type": "string"},
    "sweep": {"type": ["integer", "null"]},
    "time": {"type": ["number", "null"]},
    "box": {"type": "array", "items": {"type": "number"}},
    "species": {"type": "array", "items": {"type": "object"}},
    "species_of": {"type": "array", "items": {"type": "integer"}},
    "positions": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
    "orientations": {"type": "array", "items": {"type": "array", "items": {"type": "number"}}},
    "velocities": {"type": ["array", "null"]},
    "angular_velocities": {"type": ["array", "null"]}
  }
}"#;
