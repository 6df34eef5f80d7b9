//! The Python package (`python/`, built by maturin from the root
//! `pyproject.toml`): installed with `pip install .` into a virtual
//! environment under `target/`, then its pytest suite (`python/tests`)
//! run there, the tutorial script among them. Skipped with a message
//! where there is no `python3` with `venv`.

use std::path::{Path, PathBuf};
use std::process::Command;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// Runs `command`, failing the test with its output if it fails.
fn run(what: &str, command: &mut Command) {
    let out = command.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    assert!(
        out.status.success(),
        "{what} failed ({}):\n{}\n{}",
        out.status,
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}

fn python_with_venv() -> bool {
    Command::new("python3")
        .args(["-c", "import venv, ensurepip"])
        .output()
        .is_ok_and(|o| o.status.success())
}

#[test]
fn the_python_package_installs_and_passes_its_tests() {
    if !python_with_venv() {
        eprintln!("skipped: python3 with venv and ensurepip is needed to test the Python package");
        return;
    }
    let venv = root().join("target").join("python-venv");
    let python = venv.join("bin").join("python");
    if !python.exists() {
        run(
            "python3 -m venv",
            Command::new("python3").arg("-m").arg("venv").arg(&venv),
        );
    }
    let pip = |args: &[&str]| {
        let mut c = Command::new(&python);
        c.args(["-m", "pip", "--disable-pip-version-check", "--quiet"])
            .args(args);
        c
    };
    run(
        "pip install pytest",
        &mut pip(&["install", "pytest>=7", "matplotlib>=3.5"]),
    );
    // freud and gsd for the interoperation tests, where they install.
    let _ = pip(&["install", "freud-analysis==3.4.0", "gsd==5.0.1"]).output();
    // A local directory is built and installed again every time.
    run(
        "pip install . (builds the package)",
        pip(&["install", "."]).current_dir(root()),
    );
    run(
        "pytest python/tests",
        Command::new(&python)
            .args(["-m", "pytest", "-q", "-p", "no:cacheprovider"])
            .arg(Path::new("python").join("tests"))
            .env("HARDBODY_EXE", env!("CARGO_BIN_EXE_hardbody"))
            .env("MPLBACKEND", "Agg")
            .current_dir(root()),
    );
}
