//! GlobalCube against Monte Carlo (issue 14 §6–§7, `global-cube-mc`): error against
//! time of the standard global cube and of the particle tracer on the lounge.
//!
//! The paper has no Monte Carlo comparison; the issue asks for one. The same medium
//! (`gc-lounge`, RGB, opaque sofas, semi-transparent table, haze) is solved by the
//! global cube (levels 0, framebuffers `N`, the paper's one receiver point and the
//! default two) and traced by `wavelux_render::reference::volume` (an independent
//! particle tracer that shares no code with the projector). Error: relative L1 of the
//! red channel's collided power per `2³` block against a tracer run with many
//! particles; the tracer's own runs with fewer particles give its error against time.
//! Times are CPU seconds of this process measured in the same run.

use crate::cpu::Stopwatch;
use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use ndarray::Array3;
use wavelux::render::reference::volume::{VolumeReferenceOptions, trace_volume};
use wavelux::volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux::volume::{GlobalCubeConfig, VolumeGrid};

/// Voxels per side of the comparison blocks.
const BLOCK: usize = 2;

/// Bound on the model's collided L1 at its largest framebuffer, registered before the
/// first run: the 8³ boxes of `render/tests/volume_model.rs` measure 0.02–0.084 per
/// 2³ block at `N = 8` (the one-point gather's near-field error at this size); the
/// lounge adds opaque sofas (face gathering) and a reference with its own noise.
const MODEL_L1: f64 = 0.10;

/// `a` summed over blocks of `k³` voxels.
fn coarsen(a: &Array3<f64>, k: usize) -> Array3<f64> {
    let (nz, ny, nx) = a.dim();
    let mut out = Array3::zeros((nz / k, ny / k, nx / k));
    for ((z, y, x), v) in a.indexed_iter() {
        out[(z / k, y / k, x / k)] += v;
    }
    out
}

/// Relative L1 distance `Σ|a − b| / Σ|b|` over `2³` blocks.
fn l1(a: &Array3<f64>, b: &Array3<f64>) -> f64 {
    let (a, b) = (coarsen(a, BLOCK), coarsen(b, BLOCK));
    let num: f64 = a.iter().zip(b.iter()).map(|(x, y)| (x - y).abs()).sum();
    let den: f64 = b.iter().map(|y| y.abs()).sum();
    num / den.max(f64::MIN_POSITIVE)
}

/// Framebuffer cap of the default-projector runs ([`default_projector`]).
const DEFAULT_RUN_FRAMEBUFFER: usize = 4;

/// Bound on the relative change of the collided L1 when the default projector's
/// transport is recorded instead of re-projected at every sweep, registered before
/// the first run: the recording keeps the supersampled pixels of the sweep that records
/// (`wavelux_volume::system` docs), which moves only pixels whose contrast crosses the
/// 50 % threshold later; "errors unchanged" is read as within 2 % of the error.
const RECORDED_L1_CHANGE: f64 = 0.02;

/// The command's default solve (`GlobalCubeConfig::default()`: hierarchical, both
/// oracles, Jacobi) on the command's default projector (`CpuProjector::default()`:
/// adaptive 8 × 8 supersampling, two receiver samples per axis), framebuffer cap
/// [`DEFAULT_RUN_FRAMEBUFFER`], with the transport recorded (the default) and
/// re-projected at every sweep (`transport_memory` 0), side by side in this run: a
/// line each in `table` and the rows comparing them.
fn default_projector(
    grid: &VolumeGrid,
    want: &Array3<f64>,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<Vec<Row>> {
    let base = GlobalCubeConfig {
        framebuffer: DEFAULT_RUN_FRAMEBUFFER,
        ..GlobalCubeConfig::default()
    };
    let p = CpuProjector::default();
    let mut runs = Vec::new();
    for (label, memory) in [("recorded", base.transport_memory), ("re-projected", 0)] {
        let cfg = GlobalCubeConfig {
            transport_memory: memory,
            ..base
        };
        let sw = Stopwatch::start();
        let s = wavelux::volume::solve(grid, &cfg, &p, &mut |_| {})?;
        let secs = sw.elapsed().cpu_or_wall();
        let e = l1(&s.collided_per_voxel()[0], want);
        table.push(vec![
            format!(
                "default projector and solve, N ≤ {DEFAULT_RUN_FRAMEBUFFER}, transport {label} \
                 ({} elements, {} rays, {} gathers replayed)",
                s.elements(),
                s.work.gather.rays,
                s.work.replayed
            ),
            format!("{e:.4}"),
            format!("{:+.2e}", s.energy.balance_error()[0]),
            format!("{secs:.2}"),
        ]);
        runs.push((e, secs));
    }
    let ((e_rec, t_rec), (e_proj, t_proj)) = (runs[0], runs[1]);
    Ok(vec![
        Row::new(
            "default projector: relative change of the collided L1, recorded against re-projected transport",
            Some(0.0),
            (e_rec - e_proj).abs() / e_proj.max(f64::MIN_POSITIVE),
            "",
            Tolerance::AtMost(RECORDED_L1_CHANGE),
        )
        .comment(format!(
            "recorded {e_rec:.4}, re-projected {e_proj:.4}: the recording keeps the supersampled pixels of the sweep that records"
        )),
        Row::new(
            "default projector: CPU time re-projected / recorded (same run)",
            None,
            t_proj / t_rec.max(f64::MIN_POSITIVE),
            "",
            Tolerance::Info,
        )
        .comment(format!("{t_proj:.2} s / {t_rec:.2} s CPU")),
    ])
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    // Two receiver points cost 8x one; the full run (16³) makes them at N ≤ 4 only.
    let (side, sizes, sizes_k2, reference_particles, tracer_particles): (
        usize,
        &[usize],
        &[usize],
        u64,
        &[u64],
    ) = if ctx.quick {
        (
            8,
            &[2, 4, 8],
            &[2, 4, 8],
            1_000_000,
            &[10_000, 40_000, 160_000],
        )
    } else {
        (
            16,
            &[2, 4, 8],
            &[2, 4],
            4_000_000,
            &[40_000, 160_000, 640_000],
        )
    };
    let name = format!("gc-lounge-{side}");
    let scene = wavelux::scene::builtin::builtin(&name)
        .ok_or_else(|| anyhow::anyhow!("no built-in {name}"))?;
    let grid = VolumeGrid::from_medium(&scene.media[0])?;
    r.param(
        "scene",
        format!("builtin:{name} (RGB; errors on the red channel)"),
    );
    r.param(
        "framebuffers N",
        format!("{sizes:?} (one receiver point), {sizes_k2:?} (two)"),
    );
    r.param(
        "global cube",
        "levels 0, GMRES to 1e-6, exact chords, no supersampling; receiver samples 1 (the paper) and 2 (the default)",
    );
    r.param(
        "default projector runs",
        format!(
            "GlobalCubeConfig::default() (hierarchical, levels 2, thresholds 33/255, Jacobi \
             to 1e-4) and CpuProjector::default() (8 × 8 adaptive supersampling, receiver \
             samples 2, the command's), framebuffer cap \
             {DEFAULT_RUN_FRAMEBUFFER}, transport recorded (the default) and re-projected"
        ),
    );
    r.param(
        "reference",
        format!("particle tracer, {reference_particles} particles, seed 1"),
    );
    r.param(
        "tracer runs",
        format!("{tracer_particles:?} particles, seeds 2…"),
    );
    r.param("error", "relative L1 of collided power per 2³ block (red)");
    r.param(
        "times",
        "CPU seconds of this process, measured in the same run",
    );
    r.param(
        "build",
        if cfg!(debug_assertions) {
            "dev profile (opt-level 1): times are not release times"
        } else {
            "release"
        },
    );
    r.paper_did = "Hubeli et al. do not compare with Monte Carlo; issue 14 asks for error \
        against time against a Monte Carlo volume path tracer."
        .into();
    r.we_did = format!(
        "The lounge at {side}³ solved by the standard global cube at each N (one and two \
         receiver samples per axis) and traced with increasing particle counts; each \
         result's collided power against a tracer run with {reference_particles} \
         particles. Checked: the model's error at the largest N is within {MODEL_L1} \
         (registered before the first run, from the 8³ boxes' measured 0.02–0.084), and \
         the model's error falls as N grows. The default solve and projector (the \
         command's) run twice, with the transport recorded once per active set (the default; the \
         recording keeps the supersampled pixels of the sweep that records) and \
         re-projected at every sweep: the change of their error is held to \
         {RECORDED_L1_CHANGE} of it (registered before the first run). The tracer's \
         error and all times are info."
    );

    let sw = Stopwatch::start();
    let reference = trace_volume(
        &grid,
        &VolumeReferenceOptions {
            particles: reference_particles,
            seed: 1,
            ..VolumeReferenceOptions::default()
        },
    )?;
    let t_ref = sw.elapsed().cpu_or_wall();
    let want = &reference.collided[0];

    let mut rows = Vec::new();
    let mut model_errors = Vec::new();
    for (k, ns) in [(1u32, sizes), (2, sizes_k2)] {
        for &n in ns {
            let cfg = GlobalCubeConfig::standard(n);
            let p = CpuProjector::new(Projection::Exact, AntiAlias::OFF).with_receiver_samples(k);
            let sw = Stopwatch::start();
            let s = wavelux::volume::solve(&grid, &cfg, &p, &mut |_| {})?;
            let secs = sw.elapsed().cpu_or_wall();
            let e = l1(&s.collided_per_voxel()[0], want);
            rows.push(vec![
                format!("global cube, k = {k}, N = {n}"),
                format!("{e:.4}"),
                format!("{:+.2e}", s.energy.balance_error()[0]),
                format!("{secs:.2}"),
            ]);
            if k == 1 {
                model_errors.push(e);
            }
        }
    }
    let default_rows = default_projector(&grid, want, &mut rows)?;
    let mut tracer = Vec::new();
    for (i, &particles) in tracer_particles.iter().enumerate() {
        let sw = Stopwatch::start();
        let est = trace_volume(
            &grid,
            &VolumeReferenceOptions {
                particles,
                seed: 2 + i as u64,
                ..VolumeReferenceOptions::default()
            },
        )?;
        let secs = sw.elapsed().cpu_or_wall();
        let e = l1(&est.collided[0], want);
        rows.push(vec![
            format!("tracer, {particles} particles"),
            format!("{e:.4}"),
            "—".into(),
            format!("{secs:.2}"),
        ]);
        tracer.push((e, secs));
    }
    rows.push(vec![
        format!("reference tracer, {reference_particles} particles"),
        "0".into(),
        "—".into(),
        format!("{t_ref:.2}"),
    ]);
    r.tables.push(Table {
        title: format!("Collided power against the reference ({side}³)"),
        headers: [
            "method",
            "relative L1 (2³ blocks, red)",
            "model balance (red)",
            "CPU seconds",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });

    let last = model_errors.last().copied().unwrap_or(f64::INFINITY);
    r.rows.push(
        Row::new(
            "collided L1 of the global cube at the largest N (one receiver point)",
            None,
            last,
            "",
            Tolerance::AtMost(MODEL_L1),
        )
        .comment("issue 14 §6 asks 5 % at 32³, N = 32; this is the lounge at a smaller size"),
    );
    let rises = model_errors.windows(2).filter(|w| w[1] >= w[0]).count();
    r.rows.push(
        Row::new(
            "steps of N where the global cube's error does not fall",
            Some(0.0),
            rises as f64,
            "",
            Tolerance::AtMost(0.0),
        )
        .comment("issue 14 §6: the error falls with refinement"),
    );
    r.rows.extend(default_rows);
    if let Some(&(e, secs)) = tracer.last() {
        r.rows.push(Row::new(
            "tracer's collided L1 at its largest run",
            None,
            e,
            "",
            Tolerance::Info,
        ));
        r.rows.push(Row::new(
            "tracer's CPU seconds at its largest run",
            None,
            secs,
            "s",
            Tolerance::Info,
        ));
    }
    Ok(r)
}
