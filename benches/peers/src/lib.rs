//! Peer comparison benchmarks live in benches/peers.rs; what the benches
//! that build a peer's code share.

use std::path::{Path, PathBuf};
use std::process::Command;

/// Smallenburg's public EDMD source: `SMALLENBURG_EDMD`, or
/// `../shared/peers/smallenburg-edmd` beside the repository.
pub fn smallenburg_source() -> PathBuf {
    std::env::var_os("SMALLENBURG_EDMD")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/peers/smallenburg-edmd")
        })
}

/// Runs `cmd` to success (else panics with its output); its standard
/// output.
pub fn run(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{cmd:?}: {e}"));
    assert!(
        out.status.success(),
        "{cmd:?}: {}\n{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}
