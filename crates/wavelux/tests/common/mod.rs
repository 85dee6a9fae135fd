//! Helpers shared by the integration tests of the `wavelux` binary: run the real
//! executable in a directory and check its exit status and stderr.

#![allow(dead_code)] // each test binary uses its own subset

use std::path::Path;
use std::process::{Command, Output};

/// The `wavelux` executable Cargo built for these tests.
pub const EXE: &str = env!("CARGO_BIN_EXE_wavelux");

/// Small meshless settings shared by the meshless and device tests (a few seconds in
/// the dev profile).
pub const MESHLESS_SMALL: &[&str] = &[
    "--levels",
    "2",
    "--sender-levels",
    "1",
    "--gather-rays",
    "16",
    "--emitter-samples",
    "4",
    "--no-image",
    "--quiet",
];

/// Runs `wavelux ARGS` in `cwd`; the exit status is not checked.
pub fn run(args: &[&str], cwd: &Path) -> Output {
    Command::new(EXE)
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("the wavelux binary runs")
}

/// Runs `wavelux ARGS` in `cwd`; an error carrying its stderr unless it succeeded.
pub fn succeeds(args: &[&str], cwd: &Path) -> anyhow::Result<Output> {
    let out = run(args, cwd);
    anyhow::ensure!(
        out.status.success(),
        "wavelux {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Ok(out)
}

/// Asserts that `wavelux ARGS` fails in `cwd` with `needle` in its stderr.
pub fn fails(args: &[&str], cwd: &Path, needle: &str) {
    let out = run(args, cwd);
    assert!(!out.status.success(), "wavelux {args:?} should fail");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(needle),
        "stderr of {args:?} lacks {needle:?}: {err}"
    );
}
