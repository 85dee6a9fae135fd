//! `wavelux solve --method global-cube` (GlobalCube §5): the built-in lounge and a
//! voxelised Cornell box at small sizes, their outputs (JSON energy account, raw grid,
//! slices, image) and the typed errors of bad options.

use std::path::Path;

use anyhow::{Context, Result};
use serde_json::Value;

mod common;
use common::run;

/// Small settings (dev profile).
const SMALL: &[&str] = &[
    "--method",
    "global-cube",
    "--width",
    "16",
    "--height",
    "12",
    "--spp",
    "1",
    "--threads",
    "2",
    "--quiet",
];

fn solve(scene: &str, extra: &[&str], cwd: &Path) -> Result<Value> {
    let mut args = vec!["solve", scene];
    args.extend_from_slice(SMALL);
    args.extend_from_slice(&["--levels", "1", "--framebuffer", "4", "--tolerance", "1e-3"]);
    args.extend_from_slice(extra);
    args.extend_from_slice(&["--out", "out"]);
    let out = run(&args, cwd);
    anyhow::ensure!(
        out.status.success(),
        "wavelux {args:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stem = scene.strip_prefix("builtin:").context("built-in")?;
    let stem = if stem == "cornell-box" {
        "cornell"
    } else {
        stem
    };
    let json = cwd.join("out").join(format!("{stem}.json"));
    Ok(serde_json::from_str(&std::fs::read_to_string(json)?)?)
}

fn triple(v: &Value) -> [f64; 3] {
    std::array::from_fn(|c| v[c].as_f64().unwrap())
}

/// The JSON's energy account is consistent: finite, non-negative, the balance error is
/// `(emitted − absorbed − escaped)/emitted`, and collisions include the absorptions.
/// (Its size is the one-point receiver's near-field bias, amplified by multiple
/// scattering: 8–11 % here; see the volume crate's docs, "Energy conservation".)
fn account(s: &Value) {
    let (e, a, x, c) = (
        triple(&s["emitted"]),
        triple(&s["absorbed"]),
        triple(&s["escaped"]),
        triple(&s["collided"]),
    );
    let bal = triple(&s["balance_error"]);
    for k in 0..3 {
        assert!(
            [e[k], a[k], x[k], c[k]]
                .iter()
                .all(|v| v.is_finite() && *v >= 0.0)
        );
        assert!(
            ((e[k] - a[k] - x[k]) / e[k] - bal[k]).abs() < 1e-12,
            "{bal:?}"
        );
        assert!(c[k] >= a[k], "collided {c:?} < absorbed {a:?}");
        assert!(bal[k].abs() < 0.25, "balance {bal:?}");
    }
}

#[test]
fn lounge_outputs_and_energy_account() -> Result<()> {
    let dir = tempfile::tempdir()?;
    // The paper's one receiver point: the default two cost this file 31.5 s of CPU
    // instead of 12.9 s (measured); the Cornell box below runs the default.
    let v = solve(
        "builtin:gc-lounge-8",
        &["--receiver-samples", "1"],
        dir.path(),
    )?;
    assert_eq!(v["method"]["name"], "global-cube");
    assert_eq!(v["method"]["global_cube"]["levels"], 1);
    assert_eq!(v["method"]["global_cube"]["receiver_samples"], 1);
    let s = &v["statistics"]["volume"];
    assert_eq!(s["side"], 8);
    // The lamp's 60/54/42 W, whatever the resolution.
    let emitted = triple(&s["emitted"]);
    for (e, want) in emitted.iter().zip([60.0, 54.0, 42.0]) {
        assert!((e - want).abs() < 1e-9 * want, "{emitted:?}");
    }
    account(s);
    let steps = s["steps"].as_array().context("steps")?;
    assert_eq!(steps.first().context("a step")?["kind"], "lowpass");
    assert_eq!(steps.last().context("a step")?["kind"], "final");
    // Files: raw grid of side³ × 3 f32, three slices, the image.
    let at = |p: &Value| dir.path().join(p.as_str().unwrap_or_default());
    let raw = std::fs::metadata(at(&v["outputs"]["volume_emission"]))?;
    assert_eq!(raw.len(), 8 * 8 * 8 * 3 * 4);
    let slices = v["outputs"]["volume_slices"].as_array().context("slices")?;
    assert_eq!(slices.len(), 3);
    for p in slices {
        assert!(at(p).exists(), "{p}");
    }
    let png = wavelux::render::Image::read_png(&at(&v["outputs"]["png"]))?;
    assert_eq!((png.width, png.height), (16, 12));
    assert!(png.pixels.iter().any(|p| p[0] > 0.0), "a black image");
    Ok(())
}

#[test]
fn voxelised_cornell_box_keeps_its_power() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let v = solve(
        "builtin:cornell-box",
        &["--voxelize", "8", "--no-image"],
        dir.path(),
    )?;
    assert_eq!(
        v["method"]["global_cube"]["receiver_samples"], 2,
        "the default"
    );
    let s = &v["statistics"]["volume"];
    assert_eq!(s["voxelized"], 8);
    let want = triple(&v["scene"]["emitted_power"]);
    let got = triple(&s["emitted"]);
    for c in 0..3 {
        assert!(
            (got[c] - want[c]).abs() <= 1e-9 * want[c],
            "{got:?} vs {want:?}"
        );
    }
    account(s);
    Ok(())
}

/// The `f32` values of a raw emission grid.
fn raw_values(p: &Path) -> Result<Vec<f64>> {
    let bytes = std::fs::read(p)?;
    Ok(bytes
        .chunks_exact(4)
        .map(|b| f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])))
        .collect())
}

/// `compare A.raw B.raw` (issue 14 §5): GlobalCube eq. (35)'s `Q_square` and the RMS
/// difference of two emission grids, against the same sums over the files' values; a
/// grid against itself gives 0; a file that is not a grid is an error naming it.
#[test]
fn compare_gives_q_square_and_rms_of_two_emission_grids() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let mut grids = Vec::new();
    for (sub, k) in [("a", "2"), ("b", "1")] {
        let cwd = dir.path().join(sub);
        std::fs::create_dir_all(&cwd)?;
        let v = solve(
            "builtin:gc-lounge-8",
            &["--no-image", "--receiver-samples", k],
            &cwd,
        )?;
        let raw = v["outputs"]["volume_emission"].as_str().context("raw")?;
        grids.push(cwd.join(raw));
    }
    let compare = |a: &Path, b: &Path| -> Result<Value> {
        let json = dir.path().join("m.json");
        let (a, b, j) = (a.to_str(), b.to_str(), json.to_str());
        let args = [
            "compare",
            a.context("a")?,
            b.context("b")?,
            "--json",
            j.context("j")?,
            "-q",
        ];
        let out = run(&args, dir.path());
        anyhow::ensure!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        Ok(serde_json::from_str(&std::fs::read_to_string(json)?)?)
    };
    let m = compare(&grids[0], &grids[1])?;
    assert_eq!(m["kind"], "volume");
    assert_eq!(m["side"], 8);
    let (a, b) = (raw_values(&grids[0])?, raw_values(&grids[1])?);
    let n = a.len() as f64;
    let sq: f64 = a.iter().zip(&b).map(|(x, y)| (x - y) * (x - y)).sum();
    let (q, r) = (
        m["q_square"].as_f64().context("q")?,
        m["rms"].as_f64().context("rms")?,
    );
    assert!(sq > 0.0, "the two solves differ");
    assert!((q - sq.sqrt() / n).abs() <= 1e-12 * q, "{q}");
    assert!((r - (sq / n).sqrt()).abs() <= 1e-12 * r, "{r}");
    let same = compare(&grids[0], &grids[0])?;
    assert_eq!(same["q_square"], 0.0);
    assert_eq!(same["rms"], 0.0);
    let bad = dir.path().join("bad.raw");
    std::fs::write(&bad, [0u8; 10])?;
    let out = run(
        &[
            "compare",
            bad.to_str().context("bad")?,
            grids[0].to_str().context("a")?,
        ],
        dir.path(),
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("bad.raw"));
    Ok(())
}

#[test]
fn bad_options_are_errors() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let cwd = dir.path();
    for (scene, extra, needle) in [
        ("builtin:cornell-box", &[][..], "--voxelize"),
        (
            "builtin:cornell-box",
            &["--voxelize", "12"][..],
            "power of two",
        ),
        (
            "builtin:gc-lounge-8",
            &["--oracle", "kernel"][..],
            "--oracle kernel",
        ),
        (
            "builtin:gc-lounge-8",
            &["--solver", "cgnr"][..],
            "--solver cgnr",
        ),
        (
            "builtin:gc-lounge-8",
            &["--medium", "fog"][..],
            "no medium \"fog\"",
        ),
        (
            "builtin:gc-lounge-8",
            &["--framebuffer", "0"][..],
            "framebuffer",
        ),
        ("builtin:gc-lounge-8", &["--levels", "4"][..], "levels"),
        ("builtin:gc-lounge-8", &["--threshold=-1"][..], "threshold"),
        (
            "builtin:gc-lounge-8",
            &["--receiver-samples", "0"][..],
            "--receiver-samples 0",
        ),
    ] {
        let mut args = vec!["solve", scene];
        args.extend_from_slice(SMALL);
        args.extend_from_slice(extra);
        args.extend_from_slice(&["--out", "out", "--no-image"]);
        let out = run(&args, cwd);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // Gathering refuses the global cube's oracles.
    let out = run(
        &[
            "solve",
            "builtin:cornell-box",
            "--oracle",
            "both",
            "--no-image",
            "--out",
            "out",
        ],
        cwd,
    );
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("global-cube"));
    Ok(())
}
