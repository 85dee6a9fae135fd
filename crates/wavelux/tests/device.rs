//! `--device cpu|gpu|auto` (issue 17, "Device selection"): the JSON's `method.device`,
//! exit status 2 without a device, `auto`'s recorded fallbacks, and (in builds with the
//! `gpu` feature, on any wgpu adapter, Mesa lavapipe in CI) the global cube on the GPU
//! against the CPU. Without an adapter the GPU test prints `SKIPPED: no wgpu adapter`
//! and passes, unless `WAVELUX_REQUIRE_ADAPTER=1`.

use std::path::Path;
use std::process::{Command, Output};

use anyhow::{Context, Result};
use serde_json::Value;

mod common;
use common::EXE;

/// A small global-cube solve (dev profile): the 8³ lounge, one coarse level.
const SMALL: &[&str] = &[
    "solve",
    "builtin:gc-lounge-8",
    "--method",
    "global-cube",
    "--levels",
    "1",
    "--framebuffer",
    "4",
    "--tolerance",
    "1e-3",
    "--no-image",
    "--threads",
    "2",
    "--quiet",
    "--out",
    "out",
];

/// The settings the GPU projector implements.
const GPU_SETTINGS: &[&str] = &["--receiver-samples", "1", "--supersample", "1"];

/// Runs `wavelux SMALL EXTRA` in `cwd` with the environment `env`.
fn run(extra: &[&str], env: &[(&str, &str)], cwd: &Path) -> Output {
    let mut c = Command::new(EXE);
    c.args(SMALL).args(extra).current_dir(cwd);
    for (k, v) in env {
        c.env(k, v);
    }
    c.output().expect("the wavelux binary runs")
}

/// Runs and reads the JSON result.
fn solve(extra: &[&str], env: &[(&str, &str)], cwd: &Path) -> Result<Value> {
    let out = run(extra, env, cwd);
    anyhow::ensure!(
        out.status.success(),
        "wavelux {extra:?} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(cwd.join("out/gc-lounge-8.json"))?;
    Ok(serde_json::from_str(&text)?)
}

/// The Vulkan loader finds no driver.
const NO_DRIVER: &[(&str, &str)] = &[
    ("VK_DRIVER_FILES", "/nonexistent/wavelux-no-driver.json"),
    ("VK_ICD_FILENAMES", "/nonexistent/wavelux-no-driver.json"),
    ("WGPU_ADAPTER_NAME", ""),
];

#[test]
fn the_cpu_is_the_default_and_is_recorded() -> Result<()> {
    let dir = tempfile::tempdir()?;
    // The settings the GPU has a kernel for (the cheap ones): the CPU is still the
    // default device.
    let v = solve(GPU_SETTINGS, &[], dir.path())?;
    let d = &v["method"]["device"];
    assert_eq!(d["requested"], "cpu");
    assert_eq!(d["used"], "cpu");
    assert!(d["adapter"].is_null() && d["fallback"].is_null(), "{d}");
    assert!(v["statistics"]["device_rays"].is_null());
    assert!(v["statistics"]["deferred_rays"].is_null());
    Ok(())
}

#[test]
fn gpu_without_a_device_exits_2_and_writes_nothing() -> Result<()> {
    let dir = tempfile::tempdir()?;
    let out = run(&["--device", "gpu"], NO_DRIVER, dir.path());
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{err}");
    let why = if wavelux::GPU {
        "no GPU adapter found (install mesa-vulkan-drivers for a software one)"
    } else {
        "built without the `gpu` feature"
    };
    assert!(err.contains(why), "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dir.path().join("out/gc-lounge-8.json").exists());
    Ok(())
}

#[test]
fn auto_records_why_it_used_the_cpu() -> Result<()> {
    let dir = tempfile::tempdir()?;
    // No kernel for these settings (the pyramid projection; the default
    // supersampling has none either, which the GPU test's `--strict` run checks, but
    // costs 20 times more here): the adapter is not even opened.
    let v = solve(
        &[
            "--device",
            "auto",
            "--projection",
            "pyramid",
            "--supersample",
            "1",
            // The default two receiver points cost 8 times more here.
            "--receiver-samples",
            "1",
        ],
        &[],
        dir.path(),
    )?;
    let d = &v["method"]["device"];
    assert_eq!(
        (&d["requested"], &d["used"]),
        (&"auto".into(), &"cpu".into())
    );
    let why = d["fallback"].as_str().context("a fallback reason")?;
    assert!(why.contains("--projection pyramid"), "{why}");
    assert!(d["adapter"].is_null(), "{d}");
    // A kernel but no device.
    let v = solve(
        &[GPU_SETTINGS, &["--device", "auto"]].concat(),
        NO_DRIVER,
        dir.path(),
    )?;
    let d = &v["method"]["device"];
    assert_eq!(d["used"], "cpu");
    let why = d["fallback"].as_str().context("a fallback reason")?;
    let want = if wavelux::GPU {
        "no GPU adapter found"
    } else {
        "built without the `gpu` feature"
    };
    assert!(why.contains(want), "{why}");
    assert!(v["warnings"].as_array().is_some_and(Vec::is_empty), "{v}");
    Ok(())
}

/// The wgpu adapter the GPU tests run on, or `None` after printing `SKIPPED` (a
/// missing adapter fails instead under `WAVELUX_REQUIRE_ADAPTER=1`).
#[cfg(feature = "gpu")]
fn adapter() -> Option<std::sync::Arc<wavelux::gpu::Gpu>> {
    match wavelux::gpu::Gpu::new() {
        Ok(g) => Some(g),
        Err(e) => {
            assert!(
                std::env::var("WAVELUX_REQUIRE_ADAPTER").as_deref() != Ok("1"),
                "no wgpu adapter and WAVELUX_REQUIRE_ADAPTER=1: {e}"
            );
            eprintln!("SKIPPED: no wgpu adapter ({e})");
            None
        }
    }
}

/// The same emitted power; absorbed and escaped power within the projector's f32
/// contract, 1e-5 relative.
#[cfg(feature = "gpu")]
fn energy_agrees(cpu: &Value, gpu: &Value) -> Result<()> {
    let (c, g) = (&cpu["statistics"]["volume"], &gpu["statistics"]["volume"]);
    for key in ["emitted", "absorbed", "escaped"] {
        for ch in 0..3 {
            let (x, y) = (
                c[key][ch].as_f64().context("cpu")?,
                g[key][ch].as_f64().context("gpu")?,
            );
            let tol = if key == "emitted" { 1e-12 } else { 1e-5 };
            eprintln!(
                "  {key}[{ch}]: cpu {x} gpu {y} relative {:.2e}",
                ((x - y) / x).abs()
            );
            assert!(
                (x - y).abs() <= tol * x.abs(),
                "{key}[{ch}]: cpu {x} gpu {y}"
            );
        }
    }
    Ok(())
}

/// The GPU runs the global cube's projection; the energy account agrees with the
/// CPU's to the projector's f32 contract.
#[cfg(feature = "gpu")]
#[test]
fn the_global_cube_on_the_gpu_agrees_with_the_cpu() -> Result<()> {
    let Some(gpu) = adapter() else {
        return Ok(());
    };
    let a = gpu.adapter().clone();
    drop(gpu);
    eprintln!("adapter: {} ({}, {})", a.name, a.device_type, a.driver);
    let dir = tempfile::tempdir()?;
    // Two receiver samples per axis (8 rays per pixel from each cell; the conserving
    // escape on the CPU); one sample is the projector tests' case.
    let k2: &[&str] = &["--receiver-samples", "2", "--supersample", "1"];
    let cpu = solve(k2, &[], dir.path())?;
    let v = solve(&[k2, &["--device", "gpu"]].concat(), &[], dir.path())?;
    let d = &v["method"]["device"];
    assert_eq!(
        (&d["requested"], &d["used"]),
        (&"gpu".into(), &"gpu".into())
    );
    assert_eq!(d["adapter"], a.name.as_str());
    assert_eq!(d["device_type"], a.device_type.as_str());
    assert!(d["fallback"].is_null(), "{d}");
    let s = &v["statistics"];
    assert!(s["device_rays"].as_u64().is_some_and(|r| r > 0), "{s}");
    assert_eq!(s["deferred_rays"], 0);
    assert!(
        v["statistics"]["volume"]["projector"]
            .as_str()
            .is_some_and(|p| p.starts_with("gpu-exact")),
        "{}",
        v["statistics"]["volume"]["projector"]
    );
    // The energy account: the same emitted power; absorbed and escaped power within
    // the projector's f32 contract, 1e-5 relative. The GPU takes the CPU's path
    // through the grid ray for ray, tie rule and crossing decisions included
    // (wavelux_gpu::projector, "Ties"); measured 2026-11-25 on lavapipe: 7e-8 here,
    // 1.9e-7 with one receiver sample (2.1e-2 before the WGSL had the tie rule, 1.2e-3
    // with f32 crossing decisions).
    energy_agrees(&cpu, &v)?;
    // With no kernel for the settings, `gpu` warns, which `--strict` refuses.
    let out = run(&["--device", "gpu", "--strict"], &[], dir.path());
    assert_eq!(out.status.code(), Some(1));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--device gpu") && err.contains("--supersample"),
        "{err}"
    );
    assert!(err.contains("--strict"), "{err}");
    Ok(())
}

/// `relight`'s transfer product on the GPU: the same per-surface means as the CPU to
/// f32 rounding, and the device in the JSON.
#[cfg(feature = "gpu")]
#[test]
fn relight_on_the_gpu_agrees_with_the_cpu() -> Result<()> {
    if adapter().is_none() {
        return Ok(());
    }
    let dir = tempfile::tempdir()?;
    let relight = |device: &str| -> Result<Value> {
        let mut args = vec!["relight", "builtin:cornell-box"];
        args.extend_from_slice(common::MESHLESS_SMALL);
        args.extend_from_slice(&[
            "--light",
            "point:pos=0.1,0.3,0.2,rgb=0.5,0.4,0.3",
            "--device",
            device,
            "--out",
            "out",
        ]);
        common::succeeds(&args, dir.path())?;
        let text = std::fs::read_to_string(dir.path().join("out/cornell.relight.json"))?;
        Ok(serde_json::from_str(&text)?)
    };
    let (cpu, gpu) = (relight("cpu")?, relight("gpu")?);
    assert_eq!(cpu["device"]["used"], "cpu");
    assert_eq!(gpu["device"]["used"], "gpu", "{}", gpu["device"]);
    assert!(
        gpu["backend"]
            .as_str()
            .is_some_and(|b| b.starts_with("wgpu:"))
    );
    let means = |v: &Value| -> Result<Vec<f64>> {
        let s = v["frames"][0]["surfaces"].as_array().context("surfaces")?;
        let mut out = Vec::new();
        for x in s {
            for k in ["indirect", "radiosity"] {
                for c in 0..3 {
                    out.push(x[k][c].as_f64().context("a number")?);
                }
            }
        }
        Ok(out)
    };
    let (c, g) = (means(&cpu)?, means(&gpu)?);
    assert_eq!(c.len(), g.len());
    let scale = c.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    assert!(scale > 0.0);
    // S·e agrees to 1e-6·(|S||e|) per coefficient; the means inherit that (1e-4 of the
    // brightest mean leaves room for sign cancellation in e, and catches any wrong
    // product, which is off by O(1)).
    for (x, y) in c.iter().zip(&g) {
        assert!((x - y).abs() <= 1e-4 * scale, "cpu {x} gpu {y}");
    }
    Ok(())
}

/// The surface method's shadow rays on the GPU (recorded, answered in batches by
/// `GpuOcclusion`, replayed): the Cornell box (Haar, the target-error loop) and
/// Ziegler's occluded scene (M2, fixed threshold) at quick settings give the CPU's
/// JSON bitwise, apart from times, the device and its ray counts.
#[cfg(feature = "gpu")]
#[test]
fn the_surface_method_on_the_gpu_is_bitwise_the_cpu() -> Result<()> {
    if adapter().is_none() {
        return Ok(());
    }
    let dir = tempfile::tempdir()?;
    let cases: [(&str, &str, &[&str]); 2] = [
        (
            "builtin:cornell-box",
            "cornell",
            &["--target-error", "0.2", "--max-level", "2"],
        ),
        (
            "builtin:ziegler-occluded",
            "ziegler-occluded",
            &["--basis", "m2", "--eps", "5e-3", "--max-level", "2"],
        ),
    ];
    for (scene, stem, extra) in cases {
        let json = |device: &str| -> Result<Value> {
            let mut args = vec!["solve", scene, "--no-image", "--quiet", "--out", "out"];
            args.extend_from_slice(extra);
            args.extend_from_slice(&["--device", device]);
            common::succeeds(&args, dir.path())?;
            let text = std::fs::read_to_string(dir.path().join(format!("out/{stem}.json")))?;
            Ok(serde_json::from_str(&text)?)
        };
        let (cpu, gpu) = (json("cpu")?, json("gpu")?);
        let d = &gpu["method"]["device"];
        assert_eq!(d["used"], "gpu", "{d}");
        let s = &gpu["statistics"];
        let (dev, def) = (
            s["device_rays"].as_u64().context("device_rays")?,
            s["deferred_rays"].as_u64().context("deferred_rays")?,
        );
        eprintln!(
            "{scene}: device rays {dev}, deferred {def}, of {}",
            s["solver_rays"]
        );
        assert!(dev > 0, "{s}");
        assert_eq!(cpu["surfaces"], gpu["surfaces"]);
        for key in [
            "solver_rays",
            "kernel_evaluations",
            "oracle_evaluations",
            "elements",
            "leaves",
            "links",
            "iterations",
            "residual_history",
            "energy",
        ] {
            assert_eq!(cpu["statistics"][key], gpu["statistics"][key], "{key}");
        }
        let target = |v: &Value| -> Value {
            let mut t = v["statistics"]["target"].clone();
            if let Some(rounds) = t["rounds"].as_array_mut() {
                for r in rounds {
                    for k in ["time_refine_s", "time_solve_s", "time_estimate_s"] {
                        r[k] = Value::Null;
                    }
                }
            }
            t
        };
        assert_eq!(target(&cpu), target(&gpu));
    }
    Ok(())
}

/// The surface solver's non-standard gather of Ziegler's occluded scene on the GPU (`GpuMatVec`, f32 with
/// compensated sums, `wavelux_solver::matvec`): GMRES on the device, then iterative
/// refinement in f64 meets the tolerance 1e-10 on the f64 operator, and the solution
/// agrees with the CPU's to 1e-8 of its largest coefficient.
#[cfg(feature = "gpu")]
#[test]
fn the_gather_on_the_gpu_is_refined_to_the_tolerance() -> Result<()> {
    use wavelux::solver::{Backends, LinearMethod, SolverConfig, solve_on};
    let Some(gpu) = adapter() else {
        return Ok(());
    };
    let mv = wavelux::gpu::GpuMatVec::new(gpu);
    let scene = wavelux::scene::builtin::occluded();
    let cfg = SolverConfig {
        eps: 5e-3,
        max_level: 2,
        linear_method: LinearMethod::Gmres { restart: 30 },
        tolerance: 1e-10,
        ..SolverConfig::default()
    };
    let cpu = solve_on(&scene, &cfg, Backends::default())?;
    let dev = solve_on(
        &scene,
        &cfg,
        Backends {
            matvec: Some(&mv),
            ..Backends::default()
        },
    )?;
    assert!(
        dev.stats.device_failure.is_none(),
        "{:?}",
        dev.stats.device_failure
    );
    for c in &dev.convergence {
        eprintln!(
            "  GPU gather: {} records, final f64 relative residual {:.2e}",
            c.iterations.len(),
            c.final_relative_residual
        );
        assert!(c.converged && c.final_relative_residual <= cfg.tolerance);
    }
    let (a, b): (Vec<f64>, Vec<f64>) = (
        (0..3).flat_map(|c| cpu.leaf_coefficients(c)).collect(),
        (0..3).flat_map(|c| dev.leaf_coefficients(c)).collect(),
    );
    let scale = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let diff = a
        .iter()
        .zip(&b)
        .fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
    eprintln!("  max |x_gpu - x_cpu| / max |x_cpu| = {:.2e}", diff / scale);
    assert!(diff <= 1e-8 * scale, "{:e}", diff / scale);
    Ok(())
}
