//! `--target-error E` (with `--method gather`): wavelet radiosity solved to a target
//! relative L1 error of the radiosity function by refine–solve–estimate rounds
//! (`wavelux_solver::target`, Ziegler's refine–solve loop driven by the a-posteriori
//! estimate of `wavelux_solver::estimate`). The solver chooses the basis (unless
//! `--basis`), the initial threshold and the refinement depth; `--max-level` is only a
//! safety limit. What it chose, and every round, go into `statistics.target`.

use anyhow::{Context, bail};
use wavelux::solver::{LinearMethod, TargetConfig, TargetOutcome, solve_to_target_on};

use super::device::backends;
use super::wavelet::{basis_kind, finish, visibility};
use super::{Job, Method, Outcome, name_of, secs};
use crate::cli::{BasisArg, MethodArg, SolveArgs, SolverArg, VisibilityArg};
use crate::progress;
use crate::report;

/// Default safety limit on the element level.
const MAX_LEVEL: u8 = 10;

/// The target of a gathering solve that names no threshold (relative L1 of the
/// radiosity function). See [`default_target`].
pub const DEFAULT_TARGET: f64 = 0.02;

/// The target error a solve runs to when it names none: [`DEFAULT_TARGET`] for
/// `--method gather` (the default method) unless `--eps`, `--oracle` or `--max-level`
/// ask for one fixed-threshold refinement, the linear solver is Southwell (shooting),
/// or the basis is CDV (not a tree basis; the loop needs one). `None` otherwise.
///
/// Why a target by default: the former default (kernel oracle, ε = 0.01, level 2)
/// put its links by kernel smoothness alone, so the small Cornell light's links into
/// the floor stayed coarse and the floor average came out 4.4 % low (max |z| 12.7
/// against the 65 536-sample check); the target loop refines where the a-posteriori
/// estimate finds the error, and says what error it reached.
pub fn default_target(a: &SolveArgs) -> Option<f64> {
    let fixed = a.eps.is_some()
        || a.oracle.is_some()
        || a.max_level.is_some()
        || a.solver == Some(SolverArg::Southwell)
        || a.basis == Some(BasisArg::Cdv);
    (a.method == MethodArg::Gather && !fixed).then_some(DEFAULT_TARGET)
}

/// The target-error loop with a validated configuration.
struct Target {
    cfg: TargetConfig,
    solver: SolverArg,
    visibility: VisibilityArg,
}

/// The plan of `--target-error` (gathering only; `--eps` and `--oracle` conflict with
/// it in the argument parser).
pub fn plan(a: &SolveArgs, target: f64) -> anyhow::Result<Box<dyn Method>> {
    let solver = a.solver.unwrap_or(SolverArg::Gmres);
    let linear_method = match solver {
        SolverArg::Picard | SolverArg::Jacobi => LinearMethod::Picard,
        SolverArg::GaussSeidel => LinearMethod::GaussSeidel,
        SolverArg::Gmres => LinearMethod::Gmres { restart: 30 },
        SolverArg::Cgnr => LinearMethod::Cgnr,
        SolverArg::Southwell => {
            bail!("--target-error applies to --method gather, not to shooting (--solver southwell)")
        }
    };
    if a.cluster.is_some() {
        bail!(
            "--cluster applies to one fixed-threshold refinement (--eps, --oracle or \
             --max-level): the error estimate of --target-error does not see cluster links yet"
        );
    }
    let mut cfg = TargetConfig {
        target,
        basis: a.basis.map(basis_kind),
        face_target: a.face_target,
        face_channels: a.face_channels,
        ..TargetConfig::default()
    };
    cfg.solver.max_level = a.max_level.unwrap_or(MAX_LEVEL);
    cfg.solver.min_area = a.min_area;
    cfg.solver.visibility = visibility(a.visibility);
    cfg.solver.quad_points = a.quad;
    cfg.solver.linear_method = linear_method;
    cfg.solver.max_iterations = a.max_iterations;
    cfg.solver.tolerance = a.tolerance.unwrap_or(1e-6);
    if let Some(n) = a.estimate_visibility {
        cfg.estimate.vis_cells = n;
    }
    cfg.validate().context("invalid --target-error option")?;
    Ok(Box::new(Target {
        cfg,
        solver,
        visibility: a.visibility,
    }))
}

/// The JSON record of a finished loop.
fn report_of(
    scene: &wavelux::scene::Scene,
    cfg: &TargetConfig,
    out: &TargetOutcome,
) -> report::TargetReport {
    let den: f64 = out.estimate.reflected_l1.iter().sum();
    let (worst, worst_est) = out
        .estimate
        .worst_face(cfg.face_channels)
        .unwrap_or((0, 0.0));
    let worst_face = out.solution.patches.get(worst).map_or(String::new(), |p| {
        let name = &scene.surfaces[p.surface].name;
        if p.side == wavelux::solver::Side::Back {
            format!("{name} (back)")
        } else {
            name.clone()
        }
    });
    report::TargetReport {
        target: cfg.target,
        reached: out.reached,
        stop_reason: out.stop_reason.clone(),
        estimate: out.estimate.relative_l1,
        residual: if den > 0.0 {
            out.estimate.residual_l1.iter().sum::<f64>() / den
        } else {
            0.0
        },
        face_target: cfg.face_target.unwrap_or(cfg.target),
        worst_face,
        worst_face_estimate: worst_est,
        basis: out.choice.basis.name(),
        basis_reason: out.choice.basis_reason.clone(),
        eps: out.choice.eps,
        eps_reason: out.choice.eps_reason.clone(),
        tolerance: out.choice.tolerance,
        rounds: out
            .rounds
            .iter()
            .map(|r| report::TargetRound {
                links: r.links,
                leaves: r.leaves,
                refined: r.refined,
                estimate: r.estimate,
                worst_face_estimate: r.worst_patch.1,
                time_refine_s: secs(r.time_refine),
                time_solve_s: secs(r.time_solve),
                time_estimate_s: secs(r.time_estimate),
                estimate_rays: r.estimate_rays,
                estimate_reused_links: r.estimate_reused_links,
            })
            .collect(),
    }
}

impl Method for Target {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        let c = &self.cfg.solver;
        report::MethodInfo {
            name: "gather".into(),
            basis: self.cfg.basis.map(|b| b.name()),
            oracle: Some("brightness".into()),
            max_level: Some(c.max_level),
            min_area: Some(c.min_area),
            solver: Some(name_of(self.solver)),
            max_iterations: Some(c.max_iterations),
            visibility: Some(name_of(self.visibility)),
            quad: Some(c.quad_points),
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let sp = progress::spinner(job.show_progress, "refining, solving and estimating");
        let backend = job.device.occlusion(job.scene);
        let out = solve_to_target_on(job.scene, &self.cfg, backends(&backend));
        sp.finish_and_clear();
        let out = out.with_context(|| format!("solving {:?} failed", job.args.scene))?;
        job.device.record_solve(&out.solution.stats);
        stats.target = Some(report_of(job.scene, &self.cfg, &out));
        stats.time_s.estimate = out.rounds.iter().map(|r| secs(r.time_estimate)).sum();
        finish(job, out.solution, stats)
    }

    fn gpu_kernel(&self) -> Result<(), String> {
        match self.visibility {
            VisibilityArg::Off => Err("--visibility off shoots no shadow rays".into()),
            _ => Ok(()),
        }
    }

    fn describe(&self, r: &report::Result) -> String {
        let c = &self.cfg.solver;
        let t = r.statistics.target.as_ref();
        format!(
            "wavelet radiosity (gather) to target error {:.3}%: estimate {}, worst face {} after {} rounds ({}), basis {}, max level {} (safety limit), {} solver, {} visibility, {}x{} quadrature",
            100.0 * self.cfg.target,
            t.map_or("?".into(), |t| format!("{:.3}%", 100.0 * t.estimate)),
            t.map_or("?".into(), |t| format!(
                "{} {:.2}%",
                t.worst_face,
                100.0 * t.worst_face_estimate
            )),
            t.map_or(0, |t| t.rounds.len()),
            t.map_or("?".into(), |t| t.stop_reason.clone()),
            t.map_or("?".into(), |t| t.basis.clone()),
            c.max_level,
            name_of(self.solver),
            name_of(self.visibility),
            c.quad_points,
            c.quad_points,
        )
    }
}

#[cfg(test)]
mod tests {
    use clap::Parser;

    use super::{DEFAULT_TARGET, default_target};
    use crate::cli::SolveOnly;

    fn target_of(args: &[&str]) -> Option<f64> {
        let mut v = vec!["wavelux"];
        v.extend_from_slice(args);
        default_target(&SolveOnly::try_parse_from(v).expect("valid arguments").args)
    }

    /// A gathering solve that names no threshold runs to the default target; one that
    /// names a fixed threshold, another method, shooting or CDV does not.
    #[test]
    fn the_default_target_applies_only_without_a_fixed_threshold() {
        assert_eq!(target_of(&[]), Some(DEFAULT_TARGET));
        assert_eq!(
            target_of(&["builtin:office", "--basis", "m2"]),
            Some(DEFAULT_TARGET)
        );
        assert_eq!(
            target_of(&["--quad", "2", "--solver", "picard"]),
            Some(DEFAULT_TARGET)
        );
        for fixed in [
            &["--eps", "0.01"][..],
            &["--max-level", "2"],
            &["--oracle", "brightness"],
            &["--oracle", "kernel"],
            &["--solver", "southwell"],
            &["--basis", "cdv"],
            &["--method", "shoot"],
            &["--method", "reference"],
            &["--method", "meshless"],
        ] {
            assert_eq!(target_of(fixed), None, "{fixed:?}");
        }
    }

    fn face_of(args: &[&str]) -> Result<Option<f64>, clap::Error> {
        let mut v = vec!["wavelux"];
        v.extend_from_slice(args);
        SolveOnly::try_parse_from(v).map(|s| s.args.face_target)
    }

    /// `--face-target` takes a fraction, a percentage or `off`; it is an error where
    /// no target-error loop runs.
    #[test]
    fn the_face_target_parses_and_needs_the_target_loop() {
        assert_eq!(face_of(&[]).unwrap(), None);
        assert_eq!(face_of(&["--face-target", "3%"]).unwrap(), Some(0.03));
        assert_eq!(face_of(&["--face-target", "0.05"]).unwrap(), Some(0.05));
        assert_eq!(
            face_of(&["--face-target", "off"]).unwrap(),
            Some(f64::INFINITY)
        );
        for bad in ["0", "1.5", "nan", "-2%", "x"] {
            assert!(face_of(&["--face-target", bad]).is_err(), "{bad}");
        }
        let args = SolveOnly::try_parse_from(["wavelux", "--face-target", "3%", "--eps", "0.01"])
            .expect("valid arguments")
            .args;
        let err = crate::pipeline::plan(&args).err().expect("an error");
        assert!(err.to_string().contains("--face-target"), "{err}");
        let args = SolveOnly::try_parse_from(["wavelux", "--face-target", "3%"])
            .expect("valid arguments")
            .args;
        assert!(crate::pipeline::plan(&args).is_ok());
    }

    /// `--estimate-visibility` takes `traced` or a cell count in 1..=8; it is an
    /// error where no target-error loop runs.
    #[test]
    fn the_estimate_visibility_parses_and_needs_the_target_loop() {
        let vis_of = |args: &[&str]| {
            let mut v = vec!["wavelux"];
            v.extend_from_slice(args);
            SolveOnly::try_parse_from(v).map(|s| s.args.estimate_visibility)
        };
        assert_eq!(vis_of(&[]).unwrap(), None);
        assert_eq!(
            vis_of(&["--estimate-visibility", "traced"]).unwrap(),
            Some(0)
        );
        assert_eq!(vis_of(&["--estimate-visibility", "4"]).unwrap(), Some(4));
        for bad in ["0", "9", "-1", "x", "2.5"] {
            assert!(vis_of(&["--estimate-visibility", bad]).is_err(), "{bad}");
        }
        let args = SolveOnly::try_parse_from([
            "wavelux",
            "--estimate-visibility",
            "traced",
            "--max-level",
            "2",
        ])
        .expect("valid arguments")
        .args;
        let err = crate::pipeline::plan(&args).err().expect("an error");
        assert!(err.to_string().contains("--estimate-visibility"), "{err}");
        let args = SolveOnly::try_parse_from(["wavelux", "--estimate-visibility", "2"])
            .expect("valid arguments")
            .args;
        assert!(crate::pipeline::plan(&args).is_ok());
    }
}
