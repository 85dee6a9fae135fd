//! `--method gather` (the default): Galerkin wavelet radiosity with links (Ziegler
//! ch. 2–4) on the Virtual Mesh's supports, solved by Picard, Gauss–Seidel, GMRES or
//! CGNR.

use anyhow::{Context, bail};
use wavelux::solver::{BasisKind, LinearMethod, Oracle, SolverConfig};

use super::device::backends;
use super::wavelet::{basis_kind, finish, visibility};
use super::{Job, Method, Outcome, name_of};
use crate::cli::{BasisArg, OracleArg, SolveArgs, SolverArg, VisibilityArg};
use crate::progress;
use crate::report;

/// Default deepest level of the gathering solver.
const MAX_LEVEL: u8 = 2;

/// Gathering with a validated solver configuration.
struct Gather {
    cfg: SolverConfig,
    solver: SolverArg,
    oracle: OracleArg,
    visibility: VisibilityArg,
}

/// The gathering plan of the arguments (`--solver southwell` is planned by `shoot`).
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    let solver = a.solver.unwrap_or(SolverArg::Gmres);
    let linear_method = match solver {
        SolverArg::Picard | SolverArg::Jacobi => LinearMethod::Picard,
        SolverArg::GaussSeidel => LinearMethod::GaussSeidel,
        SolverArg::Gmres => LinearMethod::Gmres { restart: 30 },
        SolverArg::Cgnr => LinearMethod::Cgnr,
        SolverArg::Southwell => return super::shoot::plan(a),
    };
    let oracle = a.oracle.unwrap_or(OracleArg::Kernel);
    let cfg = SolverConfig {
        basis: basis_kind(a.basis.unwrap_or(BasisArg::M3)),
        eps: a.eps.unwrap_or(1e-2),
        max_level: a.max_level.unwrap_or(MAX_LEVEL),
        min_area: a.min_area,
        oracle: match oracle {
            OracleArg::Kernel => Oracle::KernelSmoothness,
            OracleArg::Brightness => Oracle::Brightness,
            o => bail!("--oracle {} applies to --method global-cube", name_of(o)),
        },
        visibility: visibility(a.visibility),
        quad_points: a.quad,
        linear_method,
        max_iterations: a.max_iterations,
        tolerance: a.tolerance.unwrap_or(1e-6),
        cluster: a.cluster,
        ..SolverConfig::default()
    };
    cfg.validate().context("invalid solver option")?;
    Ok(Box::new(Gather {
        cfg,
        solver,
        oracle,
        visibility: a.visibility,
    }))
}

impl Method for Gather {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        let c = &self.cfg;
        report::MethodInfo {
            name: "gather".into(),
            basis: Some(c.basis.name()),
            eps: Some(c.eps),
            oracle: Some(name_of(self.oracle)),
            max_level: Some(c.max_level),
            min_area: Some(c.min_area),
            solver: Some(name_of(self.solver)),
            max_iterations: Some(c.max_iterations),
            tolerance: Some(c.tolerance),
            visibility: Some(name_of(self.visibility)),
            quad: Some(c.quad_points),
            cluster: c.cluster,
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let sp = progress::spinner(job.show_progress, "refining and solving");
        let backend = job.device.occlusion(job.scene);
        let sol = wavelux::solver::solve_on(job.scene, &self.cfg, backends(&backend));
        sp.finish_and_clear();
        let sol = sol.with_context(|| format!("solving {:?} failed", job.args.scene))?;
        job.device.record_solve(&sol.stats);
        finish(job, sol, stats)
    }

    fn gpu_kernel(&self) -> Result<(), String> {
        match (self.cfg.basis, self.visibility) {
            (_, VisibilityArg::Off) => Err("--visibility off shoots no shadow rays".into()),
            (BasisKind::Cdv, _) => Err("the CDV basis traces its shadow rays on the CPU".into()),
            _ => Ok(()),
        }
    }

    fn describe(&self, _r: &report::Result) -> String {
        let c = &self.cfg;
        format!(
            "wavelet radiosity (gather), basis {}, eps {:e} ({} oracle), max level {}, {} solver, {} visibility, {}x{} quadrature",
            c.basis.name(),
            c.eps,
            name_of(self.oracle),
            c.max_level,
            name_of(self.solver),
            name_of(self.visibility),
            c.quad_points,
            c.quad_points,
        )
    }
}
