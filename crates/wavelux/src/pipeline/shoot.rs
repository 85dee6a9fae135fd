//! `--method shoot` (= `--solver southwell`): linkless hierarchical shooting on the
//! Virtual Mesh (VirtualMesh §5) in Southwell order, receivers refined on the fly.

use anyhow::{Context, bail};
use wavelux::solver::shoot::ShootConfig;

use super::wavelet::{basis_kind, finish, visibility};
use super::{Job, Method, Outcome, name_of};
use crate::cli::{BasisArg, OracleArg, SolveArgs, SolverArg, VisibilityArg};
use crate::progress;
use crate::report;

/// Default deepest level of the shooting solver.
const MAX_LEVEL: u8 = 3;

/// Shooting with a validated configuration.
struct Shoot {
    cfg: ShootConfig,
    visibility: VisibilityArg,
}

/// The shooting plan (`--method shoot` or `--solver southwell`); gathering-only flags
/// are errors.
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    if let Some(s) = a.solver.filter(|s| *s != SolverArg::Southwell) {
        bail!(
            "--solver {} applies to --method gather; shooting is Southwell iteration \
             (omit --solver or use --solver southwell)",
            name_of(s)
        );
    }
    if a.oracle.is_some_and(|o| o != OracleArg::Kernel) {
        bail!("--oracle applies to --method gather; the shooting oracle is relative to the shot");
    }
    let cfg = ShootConfig {
        basis: basis_kind(a.basis.unwrap_or(BasisArg::Haar)),
        eps: a.eps.unwrap_or(1e-2),
        max_level: a.max_level.unwrap_or(MAX_LEVEL),
        min_area: a.min_area,
        quad_points: a.quad,
        visibility: visibility(a.visibility),
        convergence: a.convergence,
        max_shots: a.max_shots,
        ..ShootConfig::default()
    };
    cfg.validate().context("invalid shooting option")?;
    Ok(Box::new(Shoot {
        cfg,
        visibility: a.visibility,
    }))
}

impl Method for Shoot {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        let c = &self.cfg;
        report::MethodInfo {
            name: "shoot".into(),
            basis: Some(c.basis.name()),
            eps: Some(c.eps),
            max_level: Some(c.max_level),
            min_area: Some(c.min_area),
            solver: Some("southwell".into()),
            visibility: Some(name_of(self.visibility)),
            quad: Some(c.quad_points),
            convergence: Some(c.convergence),
            max_shots: Some(c.max_shots),
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let sp = progress::spinner(job.show_progress, "shooting");
        let sol = wavelux::solver::shoot::shoot(job.scene, &self.cfg);
        sp.finish_and_clear();
        let sol = sol.with_context(|| format!("solving {:?} failed", job.args.scene))?;
        let st = &sol.stats;
        stats.shots = Some(st.shots);
        stats.shooting_surfaces = Some(st.shooting_surfaces);
        stats.convergence_history = st.shot_convergence.clone();
        finish(job, sol, stats)
    }

    fn describe(&self, r: &report::Result) -> String {
        let c = &self.cfg;
        let st = &r.statistics;
        format!(
            "linkless shooting on the Virtual Mesh (Southwell), basis {}, eps {:e} (relative), max level {}, convergence {} ({} shots, {} shooting surfaces), {} visibility, {}x{} quadrature",
            c.basis.name(),
            c.eps,
            c.max_level,
            st.convergence_history.last().copied().unwrap_or(0.0),
            st.shots.unwrap_or(0),
            st.shooting_surfaces.unwrap_or(0),
            name_of(self.visibility),
            c.quad_points,
            c.quad_points,
        )
    }
}
