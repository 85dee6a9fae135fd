//! Solving to a target error: refine–solve–estimate rounds until the a-posteriori
//! estimate of the radiosity function's relative L1 error is below a target.
//!
//! This is Ziegler's refine–solve loop (Alg. 2.3.4, the "multigrid-like" scheme of
//! §2.3.3: each round refines the links of the previous one and starts the solve from
//! its solution) driven by the error estimate of [`crate::estimate`] instead of a
//! fixed sequence of thresholds, in the solve–estimate–mark–refine form of adaptive
//! finite elements:
//!
//! 1. **Initial links** by the brightness-weighted oracle ("BF" refinement, Hanrahan
//!    et al. 1991) with visibility in the oracle samples, so shadow boundaries refine,
//!    at a threshold `ε₀ = target · B̄` in W/m², `B̄` the predicted mean reflected
//!    radiosity `ρ̄ Φ / A` (emitted power `Φ`, receiving area `A`, area-mean
//!    reflectance `ρ̄`), but no finer than [`INITIAL_ERROR`] (5 %) of it: the
//!    oracle's a-priori links stop paying below that, the estimate's do not.
//! 2. **Solve** (warm-started from the previous round) to a relative residual well
//!    below the target.
//! 3. **Estimate** the error per link, per leaf and in total.
//! 4. **Stop** when the estimate is at most the target and every face side's own
//!    estimated relative error ([`ErrorEstimate::patch_relative`]) is at most
//!    `face_target` (the target unless set), or when no link that carries error can
//!    be split any more (every element at the safety limits `max_level` /
//!    `min_area`), or after `max_rounds`. The per-face goal is what makes the answer
//!    right on small dim faces: a scene-wide L1 lets them be wrong by tens of
//!    percent (measured on the Cornell glTF at 2 %: short block faces +42 % / −14 %
//!    with the scene-wide goal alone, within 3.8 % with the per-face goal).
//! 5. **Mark** the links with the largest indicators, each weighted by the importance
//!    of its receiver for the goals not yet met (goal-oriented refinement: `z = w +
//!    Kᵀz`, `w` the inverse normaliser of the scene and of each face still above its
//!    goal), whose sum reaches a fraction of the total (Dörfler marking: `bulk` while
//!    the goals are far, twice the relative reduction still needed near them), and
//!    **split** them one level; go to 2.
//!
//! `max_level` is a safety limit here, not the accuracy knob: refinement goes as deep
//! as the indicators ask. The basis is chosen by [`choose_basis`] unless given. Every
//! round is recorded ([`Round`]), with what was chosen and why ([`Choice`]).

use std::time::{Duration, Instant};

use crate::basis::BasisKind;
use crate::error::SolverError;
use crate::estimate::{ErrorEstimate, EstimateCache, EstimateOptions, estimate_cached};
use crate::hierarchy::{self, LinkRec, NodeKey, Oracle};
use crate::solution::{Solution, Statistics};
use crate::{Backends, Prepared, SolverConfig, brightness, solve_links};
use wavelux_scene::Scene;

/// The relative error the initial links aim at when the target is smaller: the
/// brightness oracle's threshold `ε₀ = max(target, INITIAL_ERROR) · B̄`. Below about
/// 5 % the oracle's extra links do not lower the estimate (Cornell box, M3: 7 204
/// initial links at 5 % gave an estimate of 5.1 %, 29 681 at 2 % gave 5.0 %, 68 932
/// at 1 % gave 4.95 %); the a-posteriori rounds put the links where the error is.
pub const INITIAL_ERROR: f64 = 0.05;

/// Configuration of [`solve_to_target`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TargetConfig {
    /// Target relative L1 error of the radiosity function (`> 0`, finite; `0.01` is
    /// 1 %), as estimated by [`crate::estimate`].
    pub target: f64,
    /// Basis; `None` lets [`choose_basis`] pick.
    pub basis: Option<BasisKind>,
    /// Everything else: `max_level` and `min_area` are safety limits, `eps` is
    /// ignored (the initial threshold is derived from the target), `oracle` is
    /// ignored (brightness-weighted), the linear method and quadrature are used as
    /// given; the linear tolerance is lowered to `target / 100` when larger.
    pub solver: SolverConfig,
    /// Relative L1 error every patch (face side) must reach as well, judged by
    /// [`ErrorEstimate::patch_relative`] (`None`: the target itself; `f64::INFINITY`
    /// switches the per-face goal off). A scene-wide L1 lets small dim faces be wrong
    /// by tens of percent (the Cornell box's short block at 2 %: +42 %) because they
    /// weigh little in it.
    pub face_target: Option<f64>,
    /// Whether a face must meet its goal in every channel
    /// ([`ErrorEstimate::patch_relative_channels`], its worst channel judged, as the
    /// `cornell-faces` reproduction judges a face's mean) instead of with the channels
    /// summed ([`ErrorEstimate::patch_relative`], where a coloured face's dim channel
    /// weighs little). Off by default: on the built-in Cornell box (default target,
    /// session 29) it took 6 rounds and 152 858 links to a texel L1 of 0.892 %,
    /// against 5 rounds, 209 179 links and 0.856 % with the channels summed
    /// (docs/performance.md).
    pub face_channels: bool,
    /// Most refine–solve rounds (`≥ 1`).
    pub max_rounds: usize,
    /// Largest Dörfler fraction `θ ∈ (0, 1]`: each round splits the links with the
    /// largest indicators until their sum reaches a fraction of the total, `θ` while
    /// the goals are far, less as they come close (twice the relative reduction still
    /// needed, at least `θ/5`).
    pub bulk: f64,
    /// Options of the error estimate.
    pub estimate: EstimateOptions,
}

impl Default for TargetConfig {
    /// 1 %, the basis chosen, safety limit level 10, GMRES, 12 rounds, `θ = 0.8`
    /// (Cornell box, default target, release, one thread, side by side with main
    /// 37e5401 at `θ = 0.5` and the estimate before its finer-emitter gather: 5 rounds,
    /// 209 179 links, texel L1 0.856 %, 72.6 s CPU, against 8 rounds, 104 128 links,
    /// 1.052 %, 65.3 s; docs/performance.md, "The per-face under-read").
    fn default() -> Self {
        Self {
            target: 0.01,
            basis: None,
            solver: SolverConfig {
                max_level: 10,
                linear_method: crate::LinearMethod::Gmres { restart: 30 },
                max_iterations: 200,
                tolerance: 1e-6,
                ..SolverConfig::default()
            },
            face_target: None,
            face_channels: false,
            max_rounds: 12,
            bulk: 0.8,
            estimate: EstimateOptions::default(),
        }
    }
}

impl TargetConfig {
    /// Checks the documented ranges (and the solver's and estimate's).
    ///
    /// # Errors
    /// [`SolverError::InvalidConfig`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SolverError> {
        let bad = |field, value: String, reason| SolverError::InvalidConfig {
            field,
            value,
            reason,
        };
        if !(self.target.is_finite() && self.target > 0.0) {
            return Err(bad(
                "target",
                self.target.to_string(),
                "must be finite and > 0",
            ));
        }
        if let Some(t) = self.solver.cluster {
            return Err(bad(
                "solver.cluster",
                t.to_string(),
                "the error estimate does not see cluster links: cluster a fixed refinement",
            ));
        }
        if let Some(f) = self.face_target
            && (f.is_nan() || f <= 0.0)
        {
            return Err(bad(
                "face_target",
                f.to_string(),
                "must be > 0 (infinity switches it off)",
            ));
        }
        if self.max_rounds == 0 {
            return Err(bad("max_rounds", "0".into(), "must be >= 1"));
        }
        if !(self.bulk > 0.0 && self.bulk <= 1.0) {
            return Err(bad("bulk", self.bulk.to_string(), "must be in (0, 1]"));
        }
        if self.basis == Some(BasisKind::Cdv) {
            return Err(bad(
                "basis",
                "CDV".into(),
                "the target-error loop needs a tree basis (Haar, M2, M3)",
            ));
        }
        self.estimate.validate()?;
        self.solver.validate()
    }
}

/// What [`solve_to_target`] chose, and why.
#[derive(Debug, Clone, PartialEq)]
pub struct Choice {
    /// The basis.
    pub basis: BasisKind,
    /// Why.
    pub basis_reason: String,
    /// Initial brightness threshold `ε₀` (W/m²).
    pub eps: f64,
    /// Why.
    pub eps_reason: String,
    /// Linear-solver tolerance used (relative residual).
    pub tolerance: f64,
}

/// One refine–solve–estimate round.
#[derive(Debug, Clone, PartialEq)]
pub struct Round {
    /// Round number (0 = initial links).
    pub round: usize,
    /// Links solved with.
    pub links: usize,
    /// Leaves (unknown blocks).
    pub leaves: usize,
    /// Links split at the start of this round (the previous round's marks; for round
    /// 0 the links split by the oracle).
    pub refined: u64,
    /// Estimated relative L1 error.
    pub estimate: f64,
    /// Relative L1 of the residual alone (the local part of the estimate).
    pub residual: f64,
    /// The largest estimated relative error of a patch
    /// ([`ErrorEstimate::worst_patch`]) and that patch.
    pub worst_patch: (usize, f64),
    /// Wall time of refinement and link computation.
    pub time_refine: Duration,
    /// Wall time of the linear solves.
    pub time_solve: Duration,
    /// Wall time of the estimate.
    pub time_estimate: Duration,
    /// Shadow rays of the estimate.
    pub estimate_rays: u64,
    /// Links whose fine transport the estimate reused from the previous round.
    pub estimate_reused_links: u64,
}

/// The result of [`solve_to_target`].
#[derive(Debug, Clone)]
pub struct TargetOutcome {
    /// The last round's solution (its statistics count every round's work).
    pub solution: Solution,
    /// The estimate of that solution.
    pub estimate: ErrorEstimate,
    /// What was chosen.
    pub choice: Choice,
    /// Every round.
    pub rounds: Vec<Round>,
    /// Whether the estimate reached the target.
    pub reached: bool,
    /// Why the loop stopped.
    pub stop_reason: String,
}

/// The basis for a scene, and why: `M3` (three functions per axis) for every scene —
/// the highest-order tree basis gives the smallest error per element on the smooth
/// parts of radiosity, and its elements split where the indicators find
/// discontinuities; measured on the Cornell box in the `speed-accuracy` reproduction,
/// M3 reaches each error level with fewer links and less time than M2 or Haar.
pub fn choose_basis(prep: &Prepared) -> (BasisKind, String) {
    let _ = prep;
    (
        BasisKind::Multiwavelet(3),
        "M3: highest-order tree basis, fewest links and least time per error level on \
         smooth radiosity (speed-accuracy reproduction); discontinuities are refined \
         by the indicators"
            .into(),
    )
}

/// The predicted mean reflected radiosity `ρ̄ Φ / A` of a scene (W/m², largest
/// channel): emitted power over the receiving area times the area-mean reflectance.
pub(crate) fn mean_reflected(prep: &Prepared) -> f64 {
    let patches = &prep.patches.patches;
    let mut best: f64 = 0.0;
    for c in 0..3 {
        let (mut phi, mut area, mut rho_a) = (0.0, 0.0, 0.0);
        for p in patches {
            let a = p.support.real_area();
            phi += p.emission[c] * a;
            if p.reflects() {
                area += a;
                rho_a += p.reflectance[c] * a;
            }
        }
        if area > 0.0 {
            best = best.max(rho_a / area * phi / area);
        }
    }
    best
}

/// Solves a scene to a target error (see the module docs).
///
/// # Errors
/// [`SolverError`] for an invalid configuration or scene, and from the solves and
/// the estimate.
pub fn solve_to_target(scene: &Scene, cfg: &TargetConfig) -> Result<TargetOutcome, SolverError> {
    solve_to_target_on(scene, cfg, Backends::default())
}

/// [`solve_to_target`] on devices (see [`crate::solve_on`]): with an occlusion
/// backend alone bitwise the same outcome, the devices' work in the statistics.
///
/// # Errors
/// As [`solve_to_target`].
pub fn solve_to_target_on(
    scene: &Scene,
    cfg: &TargetConfig,
    backends: Backends<'_>,
) -> Result<TargetOutcome, SolverError> {
    cfg.validate()?;
    let (prep, choice) = choose(scene, cfg)?;
    let (occluder, failure) = prep.occluder(backends.occlusion);
    let ctx = match &occluder {
        Some(o) => prep.transfer()?.with_occluder(o.as_ref()),
        None => prep.transfer()?,
    };
    let patches = &prep.patches.patches;
    let params = prep.refine_params(choice.eps);
    let mut stats = Statistics {
        time_setup: prep.setup_time(),
        device_failure: failure,
        ..Statistics::default()
    };
    let mut rounds = Vec::new();
    let t_ref = Instant::now();
    let bright0 = |k: &NodeKey| brightness(None, patches, k);
    let (mut links, counts) = hierarchy::refine_all(&ctx, &params, &bright0);
    stats.refined_links += counts.refined;
    stats.oracle_evals += counts.oracle_evals;
    stats.nonstandard_links = counts.refined + counts.unrefined_roots;
    stats.time_refine += t_ref.elapsed();
    let mut refined = counts.refined;
    let mut split_time = t_ref.elapsed();
    let mut prev: Option<Solution> = None;
    let mut cache = EstimateCache::new();
    let mut closure_cache = crate::closure::ClosureCache::new();
    let face_target = cfg.face_target.unwrap_or(cfg.target);
    for round in 0..cfg.max_rounds {
        let (t_ref0, t_sol0) = (stats.time_refine, stats.time_solve);
        stats.stages = round + 1;
        let sol = solve_links(
            &prep,
            &ctx,
            &links,
            prev.as_ref(),
            &mut stats,
            choice.tolerance,
            backends.matvec,
            &mut closure_cache,
            None,
        )?;
        let est = estimate_cached(&ctx, &sol, &cfg.estimate, &mut cache)?;
        let times = (
            split_time + (stats.time_refine - t_ref0),
            stats.time_solve - t_sol0,
        );
        rounds.push(Round::of(round, &sol, &est, refined, times, cfg));
        let faces = est.face_errors(cfg.face_channels);
        let global_ok = est.relative_l1 <= cfg.target;
        let faces_ok = faces.iter().all(|&f| f <= face_target);
        let last = round + 1 == cfg.max_rounds;
        let marked = if global_ok && faces_ok {
            None
        } else {
            Some(mark(&ctx, &params, &sol, &est, cfg, &faces, !global_ok))
        };
        let (all, marked) = match marked {
            Some((all, marked)) if marked.iter().any(|&m| m) && !last => (all, marked),
            _ => {
                let reached = global_ok && faces_ok;
                let stop_reason = stop_reason(cfg, &est, &faces, &params, reached, last);
                return Ok(TargetOutcome {
                    solution: with_escape(sol, &prep),
                    estimate: est,
                    choice,
                    rounds,
                    reached,
                    stop_reason,
                });
            }
        };
        let t = Instant::now();
        let (new_links, counts): (Vec<LinkRec>, _) =
            hierarchy::split_marked(&ctx, &params, all, &marked);
        links = new_links;
        refined = counts.refined;
        stats.refined_links += counts.refined;
        split_time = t.elapsed();
        stats.time_refine += split_time;
        prev = Some(sol);
    }
    Err(SolverError::InvalidConfig {
        field: "max_rounds",
        value: cfg.max_rounds.to_string(),
        reason: "must be >= 1",
    })
}

/// The prepared scene of a target loop, with the basis, the initial threshold and the
/// linear tolerance chosen (see the module docs).
fn choose(scene: &Scene, cfg: &TargetConfig) -> Result<(Prepared, Choice), SolverError> {
    let mut scfg = cfg.solver;
    scfg.oracle = Oracle::Brightness;
    scfg.oracle_visibility = true;
    scfg.multigrid = None;
    // The basis decides the prepared state; choose on a first preparation.
    let probe = Prepared::new(scene, &scfg)?;
    let (basis, basis_reason) = match cfg.basis {
        Some(b) => (b, "given".to_string()),
        None => choose_basis(&probe),
    };
    scfg.basis = basis;
    let prep = if basis == probe.config.basis {
        probe
    } else {
        Prepared::new(scene, &scfg)?
    };
    let bbar = mean_reflected(&prep);
    let start = cfg.target.max(INITIAL_ERROR);
    let eps = if bbar > 0.0 { start * bbar } else { start };
    let choice = Choice {
        basis,
        basis_reason,
        eps,
        eps_reason: format!(
            "max(target {}, {INITIAL_ERROR}) x predicted mean reflected radiosity {:.4e} W/m2 \
             (reflectance-weighted emitted power per receiving area): a coarse start, the \
             estimate's rounds refine where the error is",
            cfg.target, bbar
        ),
        tolerance: scfg.tolerance.min(cfg.target * 1e-2),
    };
    Ok((prep, choice))
}

impl Round {
    /// The record of round `round`: its solution, estimate, the links split before it
    /// and the wall times of its refinement and solve.
    fn of(
        round: usize,
        sol: &Solution,
        est: &ErrorEstimate,
        refined: u64,
        (time_refine, time_solve): (Duration, Duration),
        cfg: &TargetConfig,
    ) -> Self {
        let den: f64 = est.reflected_l1.iter().sum();
        Round {
            round,
            links: sol.stats.links,
            leaves: sol.stats.leaves,
            refined,
            estimate: est.relative_l1,
            residual: if den > 0.0 {
                est.residual_l1.iter().sum::<f64>() / den
            } else {
                0.0
            },
            worst_patch: est.worst_face(cfg.face_channels).unwrap_or((0, 0.0)),
            time_refine,
            time_solve,
            time_estimate: est.time,
            estimate_rays: est.rays,
            estimate_reused_links: est.reused_links,
        }
    }
}

/// Dörfler marking of a round whose goals are not all met: the links of `sol`'s
/// hierarchy other than closure links (rebuilt by every solve: neither marked nor
/// kept), and which of them to split, among those that can still be split, by
/// their indicators weighted with the importance of their receivers for the goals
/// not yet met ([`importance`]; `global`: the scene-wide goal is one of them).
fn mark(
    ctx: &crate::TransferCtx<'_>,
    params: &hierarchy::RefineParams,
    sol: &Solution,
    est: &ErrorEstimate,
    cfg: &TargetConfig,
    faces: &[f64],
    global: bool,
) -> (Vec<LinkRec>, Vec<bool>) {
    let h = &sol.system.h;
    let face_target = cfg.face_target.unwrap_or(cfg.target);
    let weight = importance(sol, est, face_target, global, cfg.face_channels);
    let weighted: Vec<f64> = est
        .link_error
        .iter()
        .zip(&h.link_receiver)
        .map(|(e, &r)| e * weight[r as usize])
        .collect();
    let (all, link_error): (Vec<LinkRec>, Vec<f64>) = h
        .links()
        .into_iter()
        .zip(weighted)
        .filter(|(l, _)| !crate::closure::is_closure_link(&sol.patches, l))
        .unzip();
    let splittable: Vec<bool> = all
        .iter()
        .map(|l| hierarchy::can_split(ctx, &l.r, params) || hierarchy::can_split(ctx, &l.e, params))
        .collect();
    let theta = round_bulk(cfg, est, faces, face_target);
    let marked = dorfler(&link_error, &splittable, theta);
    (all, marked)
}

/// Why the loop stops: the goals `reached`, the round limit (`last`), or no link with
/// error left to split.
fn stop_reason(
    cfg: &TargetConfig,
    est: &ErrorEstimate,
    faces: &[f64],
    params: &hierarchy::RefineParams,
    reached: bool,
    last: bool,
) -> String {
    let face_target = cfg.face_target.unwrap_or(cfg.target);
    let worst = faces.iter().fold(0.0f64, |a, &b| a.max(b));
    if reached {
        format!(
            "estimate {:.4} <= target {} and every face's <= {face_target}",
            est.relative_l1, cfg.target
        )
    } else if last {
        format!(
            "round limit {} reached (estimate {:.4}, worst face {worst:.4})",
            cfg.max_rounds, est.relative_l1
        )
    } else {
        format!(
            "no link with error can be split further (estimate {:.4}, worst face {worst:.4}; \
             safety limits: max_level {}, min_area {})",
            est.relative_l1, params.max_level, params.min_area
        )
    }
}

/// Mean importance of every node of `sol`'s hierarchy for the goals not yet met, the
/// weight of a link's indicator when marking (goal-oriented refinement: an indicator
/// measures the residual a link leaves on its receiver, and the importance says how
/// much of it reaches the goals through transport).
///
/// The goal is `J(e) = ∫ w |e|` with `w = 1/D_f` on each patch whose own relative
/// error misses `face_target` (`D_f` its [`ErrorEstimate::patch_normaliser`]; with
/// `per_channel`, per channel `c` whose error misses it, `w_c = 1/D_f,c` from
/// [`ErrorEstimate::patch_normaliser_channels`]). Since
/// `e = (I − K)⁻¹ r`, `J` weights the residual by the importance `z = (I − Kᵀ)⁻¹ w`,
/// computed per channel on the leaf bases (`z = w + Kᵀ z`, Neumann iteration: `K` is
/// contractive; near `ρ = 1` the truncated series only changes the weights) and
/// taken at its largest channel. A dim face lit only by interreflection (the short
/// block's shadowed faces in the Cornell box) thus sends importance to the floor in
/// front of it and to the light's links there. When the scene-wide estimate misses
/// the target as well, `1/D` (`D = Σ_c ∫|B_h,c − E_c|`, the normaliser) is added
/// everywhere: the scene-wide goal keeps the plain indicators, so that a loop whose
/// faces all meet their goal marks exactly as without the per-face goal.
fn importance(
    sol: &Solution,
    est: &ErrorEstimate,
    face_target: f64,
    global: bool,
    per_channel: bool,
) -> Vec<f64> {
    let sys = &sol.system;
    let h = &sys.h;
    let n = h.n;
    let den: f64 = est.reflected_l1.iter().sum();
    let base = if global && den > 0.0 { 1.0 / den } else { 0.0 };
    let goal = |dp: f64, f: f64| {
        if f > face_target && dp > 0.0 {
            1.0 / dp
        } else {
            0.0
        }
    };
    let patch_w: Vec<[f64; 3]> = if per_channel {
        est.patch_normaliser_channels()
            .iter()
            .zip(est.patch_relative_channels())
            .map(|(dp, f)| std::array::from_fn(|c| goal(dp[c], f[c])))
            .collect()
    } else {
        est.patch_normaliser()
            .iter()
            .zip(est.patch_relative())
            .map(|(&dp, f)| [goal(dp, f); 3])
            .collect()
    };
    if patch_w.iter().flatten().all(|&w| w == 0.0) {
        return vec![base; h.node_count()];
    }
    let nodes = h.node_count();
    let mut best = vec![0.0f64; nodes];
    for c in 0..3 {
        // w on the leaf bases: ⟨w, φ₀⟩ = w √|leaf| (φ₀ = 1/√|leaf|).
        let mut wv = vec![0.0; sys.dim()];
        for (l, &leaf) in h.leaves.iter().enumerate() {
            let p = h.keys[leaf as usize].patch as usize;
            wv[l * n] = patch_w[p][c] * sys.node_area[leaf as usize].sqrt();
        }
        let mut z = wv.clone();
        let mut kz = vec![0.0; sys.dim()];
        for _ in 0..IMPORTANCE_ITERATIONS {
            sys.apply_kt(c, &z, &mut kz);
            for ((z, w), k) in z.iter_mut().zip(&wv).zip(&kz) {
                *z = w + k;
            }
        }
        let mut zn = vec![0.0; nodes * n];
        sys.pull_from_leaves(&z, &mut zn);
        for (i, b) in best.iter_mut().enumerate() {
            let m = zn[i * n] / sys.node_area[i].sqrt();
            *b = b.max(m);
        }
    }
    best.iter_mut().for_each(|b| *b += base);
    best
}

/// The Dörfler fraction of a round: twice the relative reduction the goals not yet
/// met still need (the scene-wide estimate down to the target, the worst face down to
/// `face_target`), between [`MIN_BULK_SHARE`] of `cfg.bulk` and `cfg.bulk`. Splitting a
/// link removes most but not all of its indicator (its children keep some), so about
/// twice the needed share is marked; a loop close to its goal then adds the links it
/// needs instead of doubling them (Cornell box, default target: the last round took
/// 81,869 links to 155,052 to bring the floor from 2.23 % below 2 %).
fn round_bulk(cfg: &TargetConfig, est: &ErrorEstimate, faces: &[f64], face_target: f64) -> f64 {
    let need = |e: f64, goal: f64| if e > goal { 1.0 - goal / e } else { 0.0 };
    let global = need(est.relative_l1, cfg.target);
    let face = faces
        .iter()
        .map(|&f| need(f, face_target))
        .fold(0.0f64, f64::max);
    (2.0 * global.max(face)).clamp(MIN_BULK_SHARE * cfg.bulk, cfg.bulk)
}

/// The smallest Dörfler fraction of a round, as a share of [`TargetConfig::bulk`]: a
/// round always splits enough to make progress.
const MIN_BULK_SHARE: f64 = 0.2;

/// Neumann iterations of the importance `z = w + Kᵀ z`: the Cornell box's operator
/// contracts by about 0.73 per application, so 30 leave `0.73³⁰ ≈ 8·10⁻⁵` of the
/// transported part (marking needs the importance to a few percent).
const IMPORTANCE_ITERATIONS: usize = 30;

/// `sol` with its escaped power measured ([`Solution::measure_escape`]).
fn with_escape(mut sol: Solution, prep: &Prepared) -> Solution {
    sol.measure_escape(prep);
    sol
}

/// Dörfler marking: the smallest set of eligible entries with the largest values
/// whose sum reaches `bulk` of the eligible total (ties broken by index, so the
/// marking is deterministic).
fn dorfler(eta: &[f64], eligible: &[bool], bulk: f64) -> Vec<bool> {
    let mut idx: Vec<usize> = (0..eta.len())
        .filter(|&i| eligible[i] && eta[i] > 0.0)
        .collect();
    let total: f64 = idx.iter().map(|&i| eta[i]).sum();
    idx.sort_by(|&a, &b| eta[b].total_cmp(&eta[a]).then(a.cmp(&b)));
    let mut marked = vec![false; eta.len()];
    let mut acc = 0.0;
    for i in idx {
        if acc >= bulk * total {
            break;
        }
        marked[i] = true;
        acc += eta[i];
    }
    marked
}
