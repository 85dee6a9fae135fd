//! `--method global-cube`: volume radiosity of a participating medium with the
//! hierarchical Global Cube (GlobalCube §2–§5, `wavelux_volume`). The medium is the
//! scene's (`--medium NAME` when it has several) or its surfaces rasterised by
//! `--voxelize N`; a scene with surfaces needs one of `--voxelize` and
//! `--ignore-surfaces`. Outputs besides the JSON (whose `statistics.volume` holds the
//! energy account, every solve step and the timings): the emission–absorption image
//! (EXR/PNG), the raw emission grid `OUT/STEM-emission.raw` (`side³ × 3` little-endian
//! `f32`, x fastest, RGB interleaved, W/m³) and three slice PNGs
//! `OUT/STEM-slice-{x,y,z}.png` through the middle of the lattice.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use wavelux::render::{ToneMap, image::write_bytes_atomic};
use wavelux::scene::Scene;
use wavelux::volume::{
    CpuProjector, GammaMode, GlobalCubeConfig, Oracle, Projection, Relaxation, Threshold,
    VolumeGrid, VolumeSolution,
    backend::cpu::{AntiAlias, MAX_RECEIVER_SAMPLES},
};

use super::{Job, Method, Outcome, name_of, secs};
use crate::cli::{GammaArg, OracleArg, ProjectionArg, SolveArgs, SolverArg};
use crate::progress;
use crate::report;

/// Default coarse levels `L` (GlobalCube §5: `M = m0 + 2`).
const DEFAULT_LEVELS: usize = 2;

/// Default tolerance: the largest relative update of the lowpass and final solves
/// (every relaxation re-runs the projector, so this is the method's main cost knob).
const DEFAULT_TOLERANCE: f64 = 1e-4;

/// Default threshold in 8-bit units (ours; the paper gives none for Table 1).
const DEFAULT_THRESHOLD: f64 = 33.0;

/// The global cube with its configuration.
struct GlobalCube {
    config: GlobalCubeConfig,
    /// `--receiver-samples` of the CPU projector.
    receiver_samples: u32,
    /// `--supersample`: sub-pixels per side of the adaptive supersampling (1: off).
    supersample: u32,
}

/// Largest `--supersample`.
const MAX_SUPERSAMPLE: u32 = 16;

/// The global cube's plan: `--levels`, `--framebuffer`, `--threshold[-source|
/// -opacity|-chi]`, `--oracle`, `--relaxations`, `--tolerance`, `--max-iterations`,
/// `--solver`, `--projection`, `--gamma`, checked by [`GlobalCubeConfig::validate`].
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    let k = a.volume.receiver_samples;
    if !(1..=MAX_RECEIVER_SAMPLES).contains(&k) {
        bail!("--receiver-samples {k} outside 1..={MAX_RECEIVER_SAMPLES}");
    }
    let s = a.volume.supersample;
    if !(1..=MAX_SUPERSAMPLE).contains(&s) {
        bail!("--supersample {s} outside 1..={MAX_SUPERSAMPLE}");
    }
    Ok(Box::new(GlobalCube {
        config: config(a)?,
        receiver_samples: k,
        supersample: s,
    }))
}

/// The configuration of the arguments (see [`plan`]).
pub fn config(a: &SolveArgs) -> anyhow::Result<GlobalCubeConfig> {
    let v = &a.volume;
    let oracle = match a.oracle.unwrap_or(OracleArg::Both) {
        OracleArg::Static => Oracle::Static,
        OracleArg::Dynamic => Oracle::Dynamic,
        OracleArg::Both => Oracle::Both,
        OracleArg::None => Oracle::None,
        o => bail!(
            "--oracle {} applies to --method gather; the global cube's are static, dynamic, both and none",
            name_of(o)
        ),
    };
    let solver = match a.solver.unwrap_or(SolverArg::Jacobi) {
        SolverArg::Jacobi | SolverArg::Picard => Relaxation::Jacobi,
        SolverArg::GaussSeidel => Relaxation::GaussSeidel,
        SolverArg::Gmres => Relaxation::Gmres,
        s => bail!(
            "--solver {} does not apply to --method global-cube (jacobi, gauss-seidel, gmres)",
            name_of(s)
        ),
    };
    let t = v.threshold.unwrap_or(DEFAULT_THRESHOLD);
    let config = GlobalCubeConfig {
        levels: a.meshless.levels.unwrap_or(DEFAULT_LEVELS),
        framebuffer: v.framebuffer,
        threshold_opacity: Threshold::Fraction(v.threshold_opacity.unwrap_or(t)),
        threshold_source: Threshold::Fraction(v.threshold_source.unwrap_or(t)),
        threshold_chi: Threshold::Fraction(v.threshold_chi.unwrap_or(t)),
        oracle,
        relaxations: v.relaxations,
        tolerance: a.tolerance.unwrap_or(DEFAULT_TOLERANCE),
        max_iterations: a.max_iterations,
        solver,
        projection: match v.projection {
            ProjectionArg::Exact => Projection::Exact,
            ProjectionArg::Pyramid => Projection::Pyramid,
        },
        gamma: match v.gamma {
            GammaArg::FirstFlight => GammaMode::FirstFlight,
            GammaArg::Normalized => GammaMode::Normalized,
            GammaArg::Printed => GammaMode::Printed,
        },
        ..GlobalCubeConfig::default()
    };
    config.validate().context("--method global-cube")?;
    Ok(config)
}

/// The grid to solve: `--voxelize N` of the surfaces, else the scene's medium
/// (`--medium NAME` among several). Returns it with the medium's name.
pub fn grid(scene: &Scene, a: &SolveArgs) -> anyhow::Result<VolumeGrid> {
    let v = &a.volume;
    if let Some(n) = v.voxelize {
        if !scene.media.is_empty() {
            bail!(
                "--voxelize rasterises surfaces; the scene also has {} medium(s) ({}), which \
                 cannot be combined with them yet: solve the media alone with --ignore-surfaces",
                scene.media.len(),
                media_names(scene)
            );
        }
        return wavelux::volume::voxelize(scene, n).context("--voxelize");
    }
    if !scene.surfaces.is_empty() && !v.ignore_surfaces {
        bail!(
            "the scene has {} surface(s) and the global cube solves media: use --voxelize N \
             to rasterise them into an N³ grid, or --ignore-surfaces to solve the media alone",
            scene.surfaces.len()
        );
    }
    let medium = match (&v.medium, scene.media.as_slice()) {
        (_, []) => bail!("the scene has no medium (use --voxelize N for a surface scene)"),
        (None, [m]) => m,
        (None, _) => bail!(
            "the scene has {} media ({}): choose one with --medium NAME",
            scene.media.len(),
            media_names(scene)
        ),
        (Some(name), media) => media.iter().find(|m| &m.name == name).with_context(|| {
            format!(
                "the scene has no medium {name:?} (media: {})",
                media_names(scene)
            )
        })?,
    };
    VolumeGrid::from_medium(medium).with_context(|| format!("medium {:?}", medium.name))
}

fn media_names(scene: &Scene) -> String {
    let names: Vec<String> = scene
        .media
        .iter()
        .map(|m| format!("{:?}", m.name))
        .collect();
    names.join(", ")
}

/// Path of the raw emission grid: `OUT/STEM-emission.raw`.
pub fn raw_path(out: &Path, stem: &str) -> PathBuf {
    out.join(format!("{stem}-emission.raw"))
}

/// Paths of the slice PNGs across x, y and z: `OUT/STEM-slice-{x,y,z}.png`.
pub fn slice_paths(out: &Path, stem: &str) -> [PathBuf; 3] {
    ["x", "y", "z"].map(|a| out.join(format!("{stem}-slice-{a}.png")))
}

impl Method for GlobalCube {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        let c = &self.config;
        report::MethodInfo {
            name: "global-cube".into(),
            oracle: Some(name_of(c.oracle)),
            solver: Some(name_of(c.solver)),
            max_iterations: Some(c.max_iterations),
            tolerance: Some(c.tolerance),
            global_cube: serde_json::to_value(c).ok().map(|mut v| {
                if let Some(o) = v.as_object_mut() {
                    o.insert("receiver_samples".into(), self.receiver_samples.into());
                    o.insert("supersample".into(), self.supersample.into());
                }
                v
            }),
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let (scene, a) = (job.scene, job.args);
        let t = Instant::now();
        let grid = grid(scene, a)?;
        stats.time_s.setup = secs(t.elapsed());

        let t = Instant::now();
        let antialias = match self.supersample {
            1 => AntiAlias::OFF,
            s => AntiAlias {
                subdivisions: s,
                ..AntiAlias::default()
            },
        };
        let cpu = CpuProjector::new(self.config.projection, antialias)
            .with_receiver_samples(self.receiver_samples);
        let sp = progress::spinner(job.show_progress, "global cube");
        let mut on_step = |r: &wavelux::volume::StepRecord| {
            sp.set_message(format!(
                "global cube: level {} {} step {}: {} cells, update {:.2e}",
                r.level, r.kind, r.step, r.elements, r.max_update
            ));
        };
        #[cfg(feature = "gpu")]
        let sol = match job.device.gpu() {
            Some(gpu) => {
                let p = super::device::FallbackProjector::new(
                    wavelux::gpu::GpuProjector::new(gpu)
                        .with_receiver_samples(self.receiver_samples),
                    cpu,
                    job.device,
                );
                wavelux::volume::solve(&grid, &self.config, &p, &mut on_step)
            }
            None => wavelux::volume::solve(&grid, &self.config, &cpu, &mut on_step),
        };
        #[cfg(not(feature = "gpu"))]
        let sol = wavelux::volume::solve(&grid, &self.config, &cpu, &mut on_step);
        let sol = sol.with_context(|| format!("global cube solve of {:?}", grid.name))?;
        sp.finish_and_clear();
        stats.time_s.solve = secs(t.elapsed());
        stats.elements = sol.elements();
        stats.leaves = sol.elements();

        let t = Instant::now();
        std::fs::create_dir_all(&a.out)
            .with_context(|| format!("cannot create the output directory {:?}", a.out))?;
        write_bytes_atomic(&raw_path(&a.out, job.stem), &sol.emission_raw())?;
        for (axis, path) in slice_paths(&a.out, job.stem).iter().enumerate() {
            wavelux::render::volume_slice(&sol, axis, sol.side / 2)?
                .write_png(path, ToneMap::Auto)?;
        }
        stats.time_s.write = secs(t.elapsed());

        let mut image = None;
        if let Some(view) = job.view {
            let t = Instant::now();
            let sp = progress::spinner(job.show_progress, "emission-absorption image");
            image = Some(wavelux::render::render_volume(&sol, view, a.spp)?);
            sp.finish_and_clear();
            stats.primary_rays = (view.width * view.height * a.spp * a.spp) as u64;
            stats.time_s.render = secs(t.elapsed());
        }
        stats.volume = Some(volume_stats(&sol, a.volume.voxelize));
        Ok(Outcome {
            surfaces: Vec::new(),
            error_estimate: None,
            error_estimate_skipped: Some(
                "the global cube solves a medium: its error against Monte Carlo is measured by \
                 render::reference::volume (tests and the global-cube reproductions)"
                    .into(),
            ),
            warnings: Vec::new(),
            image,
            solution: None,
        })
    }

    /// The GPU projector ([`wavelux::gpu::GpuProjector`] in `gpu` builds) is the exact
    /// projection with one ray per pixel and receiver sample, for 1, 2, 4 or 8 receiver
    /// samples per axis (with more than one, its escape runs on the CPU).
    fn gpu_kernel(&self) -> Result<(), String> {
        let mut missing = Vec::new();
        if self.config.projection != Projection::Exact {
            missing.push("--projection pyramid");
        }
        if !matches!(self.receiver_samples, 1 | 2 | 4 | 8) {
            missing.push("--receiver-samples other than 1, 2, 4 or 8");
        }
        if self.supersample != 1 {
            missing.push("--supersample above 1 (the default 8)");
        }
        if missing.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "the GPU projector computes the exact projection with one ray per pixel and \
                 receiver sample (--projection exact --receiver-samples 1|2|4|8 \
                 --supersample 1) and has no {}",
                missing.join(", no ")
            ))
        }
    }

    fn describe(&self, r: &report::Result) -> String {
        let c = &self.config;
        let mut s = format!(
            "hierarchical global cube, L = {}, framebuffer {}, {} oracle, {} relaxation",
            c.levels,
            c.framebuffer,
            name_of(c.oracle),
            name_of(c.solver)
        );
        if let Some(v) = &r.statistics.volume {
            s.push_str(&format!(
                ", {}³ voxels, {} cells, balance error {:.1e}",
                v.side,
                v.elements,
                v.balance_error.iter().fold(0.0f64, |m, x| m.max(x.abs()))
            ));
        }
        s
    }
}

/// The JSON's `statistics.volume`.
fn volume_stats(sol: &VolumeSolution, voxelized: Option<usize>) -> report::VolumeStats {
    report::VolumeStats {
        medium: sol.name.clone(),
        voxelized,
        side: sol.side,
        extent: sol.extent,
        voxel: sol.voxel,
        elements: sol.elements(),
        projector: sol.projector.clone(),
        emitted: sol.energy.emitted,
        absorbed: sol.energy.absorbed,
        escaped: sol.energy.escaped,
        collided: sol.energy.collided,
        balance_error: sol.energy.balance_error(),
        steps: serde_json::to_value(&sol.steps).unwrap_or_default(),
        work: serde_json::to_value(sol.work).unwrap_or_default(),
        solve_seconds: sol.seconds,
    }
}
