//! GlobalCube §5, Fig. 9: convergence of the global cube in the framebuffer side `N`.
//!
//! The paper (seed 000, §5 "Convergence", eq. (35)) plots `Q_square` between the
//! solution with a `128²` framebuffer and those with `2², 4², …, 64²`, and states that
//! the error falls as `N` grows; the figure has no numbers we can quote and the scene
//! is not named. We solve the lounge (`gc-lounge`) with the standard global cube (no
//! hierarchy) at each `N` and compare with a solution at twice the largest `N`; the
//! rows check that the error falls monotonically and report the fitted slope of
//! `log Q` against `log N`.

use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux::volume::{GlobalCubeConfig, Relaxation, VolumeGrid, VolumeSolution, q_square};

fn solve(grid: &VolumeGrid, n: usize) -> anyhow::Result<(VolumeSolution, f64)> {
    let cfg = GlobalCubeConfig {
        levels: 0,
        framebuffer: n,
        solver: Relaxation::Gmres,
        tolerance: 1e-7,
        ..GlobalCubeConfig::default()
    };
    // The paper's projector: one ray per pixel from the receiver's centre.
    let p = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    let t = crate::cpu::Stopwatch::start();
    let s = wavelux::volume::solve(grid, &cfg, &p, &mut |_| {})?;
    Ok((s, t.elapsed().cpu_or_wall()))
}

/// Least-squares slope of `ln y` against `ln x`.
fn slope(x: &[f64], y: &[f64]) -> f64 {
    let lx: Vec<f64> = x.iter().map(|v| v.ln()).collect();
    let ly: Vec<f64> = y.iter().map(|v| v.ln()).collect();
    let n = lx.len() as f64;
    let (mx, my) = (lx.iter().sum::<f64>() / n, ly.iter().sum::<f64>() / n);
    let num: f64 = lx.iter().zip(&ly).map(|(a, b)| (a - mx) * (b - my)).sum();
    let den: f64 = lx.iter().map(|a| (a - mx) * (a - mx)).sum();
    num / den
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    let (side, sizes): (usize, &[usize]) = if ctx.quick {
        (8, &[1, 2, 4])
    } else {
        (16, &[1, 2, 4, 8])
    };
    let n_ref = 2 * sizes[sizes.len() - 1];
    let name = format!("gc-lounge-{side}");
    let scene = wavelux::scene::builtin::builtin(&name)
        .ok_or_else(|| anyhow::anyhow!("no built-in {name}"))?;
    let grid = VolumeGrid::from_medium(&scene.media[0])?;
    r.param("scene", format!("builtin:{name} (RGB)"));
    r.param("framebuffers N", format!("{sizes:?}"));
    r.param("reference", format!("N = {n_ref}"));
    r.param("method", "standard global cube (levels 0), GMRES to 1e-7");
    r.param(
        "projector",
        "CPU, exact, one ray per pixel, one receiver sample",
    );
    r.param(
        "build",
        if cfg!(debug_assertions) {
            "dev profile (opt-level 1): times are not release times"
        } else {
            "release"
        },
    );
    r.paper_did = "Hubeli et al. compare solutions with framebuffers 2² … 64² against a \
        128² reference by Q_square (eq. 35) and show the error falling (Fig. 9, images; \
        no numbers, scene not named)."
        .into();
    r.we_did = format!(
        "We solve our lounge at {side}³ for each N and compare the emitted power per \
         voxel (all channels) with a solution at N = {n_ref} by Q_square (eq. 35). The \
         paper's sizes (up to 128² at 32³ or 64³) take hours on our CPU projector (cost \
         ∝ cells · N²), so the sizes are smaller; the claim checked is the same: the \
         error falls monotonically with N. The slope is reported (info)."
    );
    let (reference, t_ref) = solve(&grid, n_ref)?;
    let want = reference.emission_per_voxel();
    let mut qs = Vec::new();
    let mut rows = Vec::new();
    for &n in sizes {
        let (s, secs) = solve(&grid, n)?;
        let q = q_square(&s.emission_per_voxel(), &want)?;
        rows.push(vec![
            n.to_string(),
            format!("{q:.4e}"),
            format!("{:+.2e}", s.energy.balance_error()[0]),
            format!("{secs:.2}"),
        ]);
        qs.push(q);
    }
    rows.push(vec![
        format!("{n_ref} (reference)"),
        "0".into(),
        format!("{:+.2e}", reference.energy.balance_error()[0]),
        format!("{t_ref:.2}"),
    ]);
    r.tables.push(Table {
        title: format!("Q_square against N = {n_ref} ({side}³)"),
        headers: [
            "N",
            "Q_square (W per voxel)",
            "balance (red)",
            "CPU seconds",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    });
    let rises = qs.windows(2).filter(|w| w[1] >= w[0]).count();
    r.rows.push(
        Row::new(
            "steps of N where Q_square does not fall",
            Some(0.0),
            rises as f64,
            "",
            Tolerance::AtMost(0.0),
        )
        .comment("Fig. 9: the error falls as the framebuffer grows"),
    );
    let xs: Vec<f64> = sizes.iter().map(|&n| n as f64).collect();
    r.rows.push(
        Row::new(
            "slope of log Q_square against log N",
            None,
            slope(&xs, &qs),
            "",
            Tolerance::Info,
        )
        .comment("the paper gives images only"),
    );
    Ok(r)
}
