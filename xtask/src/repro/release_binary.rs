//! Runs the real `wavelux` command, built in release mode, as a user would: the
//! reproductions that judge the default command (`speed-accuracy`'s target rows,
//! `default-bias`) measure the binary, not a library call that might differ from it.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::cpu::{Elapsed, Stopwatch};

/// Builds `target/release/wavelux`, runs it with `args` in a fresh temporary directory
/// named after `tag` and timed by this run, and hands the directory to `read` for the
/// outputs. Returns what `read` returns and the command's wall and CPU time (the CPU
/// time of the waited-for child: every thread of the command). The directory
/// is removed afterwards, whether the run succeeded or not; a non-zero exit is an
/// error carrying the command's stderr.
pub fn run_wavelux<T>(
    tag: &str,
    args: &[&str],
    read: impl FnOnce(&Path) -> anyhow::Result<T>,
) -> anyhow::Result<(T, Elapsed)> {
    let root: PathBuf = Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .ok_or_else(|| anyhow::anyhow!("no workspace root"))?
        .to_path_buf();
    let st = Command::new(env!("CARGO"))
        .args(["build", "--release", "-p", "wavelux", "--bin", "wavelux"])
        .current_dir(&root)
        .status()?;
    anyhow::ensure!(st.success(), "cargo build --release -p wavelux failed");
    let dir = std::env::temp_dir().join(format!("wavelux-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&dir)?;
    let t = Stopwatch::start();
    let out = Command::new(root.join("target/release/wavelux"))
        .args(args)
        .current_dir(&dir)
        .output()?;
    let time = t.elapsed();
    let result = if out.status.success() {
        read(&dir)
    } else {
        let command: Vec<&str> = std::iter::once("wavelux")
            .chain(args.iter().copied())
            .collect();
        Err(anyhow::anyhow!(
            "{} failed: {}",
            command.join(" "),
            String::from_utf8_lossy(&out.stderr)
        ))
    };
    let _ = std::fs::remove_dir_all(&dir);
    Ok((result?, time))
}
