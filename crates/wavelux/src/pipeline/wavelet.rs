//! What gathering and shooting share: the mapping of the basis and visibility flags,
//! and the finish of a wavelet [`Solution`] — its statistics and energy, real-area
//! surface averages, the path-traced error check and the image (the solution's
//! radiosity at primary hits, plus the final gather of Glossy §5.5 with `--gather`).

use std::time::Instant;

use wavelux::render::{RenderOptions, SolutionField};
use wavelux::solver::{BasisKind, Solution, Visibility};

use super::{Job, Outcome, error_check, reported_back, secs, surface_result, warnings};
use crate::cli::{BasisArg, VisibilityArg};
use crate::progress;
use crate::report;

/// The solver's basis of `--basis`.
pub fn basis_kind(b: BasisArg) -> BasisKind {
    match b {
        BasisArg::Haar => BasisKind::Haar,
        BasisArg::M2 => BasisKind::Multiwavelet(2),
        BasisArg::M3 => BasisKind::Multiwavelet(3),
        BasisArg::Cdv => BasisKind::Cdv,
    }
}

/// The solver's visibility of `--visibility`.
pub fn visibility(v: VisibilityArg) -> Visibility {
    match v {
        VisibilityArg::Quadrature => Visibility::InQuadrature,
        VisibilityArg::Fractional => Visibility::Fractional,
        VisibilityArg::Off => Visibility::Off,
    }
}

/// Records the solution's statistics and energy in `stats`, takes its surface
/// averages, runs the error check (`--samples`) and renders the view.
pub fn finish(
    job: &Job<'_>,
    sol: Solution,
    stats: &mut report::Statistics,
) -> anyhow::Result<Outcome> {
    record_statistics(&sol, stats);
    let scene = job.scene;
    let surfaces: Vec<report::SurfaceResult> = (0..scene.surfaces.len())
        .map(|i| {
            let back = reported_back(scene, i);
            surface_result(scene, i, back, sol.side_average(i, back), None)
        })
        .collect();
    let mut check = Err("--samples 0".to_string());
    let mut warned = Vec::new();
    if job.args.samples > 0 {
        let t = Instant::now();
        let sp = progress::spinner(job.show_progress, "Monte Carlo error check");
        check = error_check::estimate_error(scene, &surfaces, job.args.samples, &job.reference);
        sp.finish_and_clear();
        stats.time_s.monte_carlo = secs(t.elapsed());
        if let Err(reason) = &check {
            warned.push(warnings::error_check_skipped(reason));
        }
    }
    let (error_estimate, error_estimate_skipped) = match check {
        Ok(e) => (Some(e), None),
        Err(reason) => (None, Some(reason)),
    };
    let mut image = None;
    if let Some(view) = job.view {
        let t = Instant::now();
        let field = SolutionField::new(&sol)?;
        let pb = progress::bar(job.show_progress, view.height as u64, "rendering");
        let (img, rs) = wavelux::render::render(
            &field,
            view,
            &RenderOptions {
                spp: job.args.spp,
                gather: job.args.gather,
                direct: job.args.direct,
                seed: job.args.seed,
            },
            &|k| pb.inc(k),
        )?;
        pb.finish_and_clear();
        stats.primary_rays = rs.primary_rays;
        stats.gather_rays = rs.gather_rays;
        stats.direct_rays = rs.direct_rays;
        stats.time_s.render = secs(t.elapsed());
        image = Some(img);
    }
    Ok(Outcome {
        surfaces,
        error_estimate,
        error_estimate_skipped,
        warnings: warned,
        image,
        solution: Some(sol),
    })
}

/// The solver's counters, times, residuals and energy balance.
fn record_statistics(sol: &Solution, stats: &mut report::Statistics) {
    let st = &sol.stats;
    stats.time_s.setup = secs(st.time_setup);
    stats.time_s.refine = secs(st.time_refine);
    stats.time_s.solve = secs(st.time_solve);
    stats.elements = st.elements;
    stats.leaves = st.leaves;
    stats.links = st.links;
    stats.cluster_links = st.cluster_links;
    stats.refined_links = st.refined_links;
    stats.oracle_evaluations = st.oracle_evals;
    stats.kernel_evaluations = st.kernel_evals;
    stats.solver_rays = st.rays;
    stats.solver_bytes = st.bytes;
    stats.iterations = st.iterations.clone();
    stats.residual_history = sol
        .convergence
        .iter()
        .map(|c| c.iterations.iter().map(|r| r.relative_residual).collect())
        .collect();
    stats.energy = Some(report::Energy {
        emitted: sol.energy.emitted,
        absorbed: sol.energy.absorbed,
        escaped: sol.energy.escaped,
        unshot: sol.energy.unshot,
    });
}
