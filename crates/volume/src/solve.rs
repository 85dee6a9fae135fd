//! The hierarchical global cube (GlobalCube §4, Fig. 7): solve the lowpass level,
//! then level by level refine with the static and dynamic oracles, initialise the new
//! faces by eqs. (33)–(34), relax, and re-run the dynamic oracle after every
//! relaxation until nothing refines; finally relax the last active set to the
//! tolerance.
//!
//! * Static oracle (§4.2, `refine_static`): some |detail| of `χᵗ` or σ inside the
//!   cell (the max-detail pyramid of [`crate::hierarchy`]) reaches its threshold.
//! * Dynamic oracle (`refine_dynamic`): two faces of the cell differ by at least
//!   `threshold_chi` (W, any channel).
//!
//! Both compare with `≥`, so threshold 0 refines everything and reproduces the
//! standard (non-hierarchical) global cube. The paper's thresholds are 8-bit values
//! (Fig. 10: 13 … 93); [`Threshold::Fraction`] `t` means `t/255` of the quantity's
//! range (σ and `χᵗ` over the input, face powers over the lowpass solution).
//! Eq. (33)'s `χ^f` is read as the source `χᵗ` (the paper never defines it); face
//! powers of a child are a quarter of the parent face's (a child face has a quarter of
//! its area).

use std::time::Instant;

use crate::active::{ActiveSet, Origin, WeightCache};
use crate::backend::cpu::Projection;
use crate::backend::{FaceRgb, Projector};
use crate::cell::{Collision, GammaMode, SelfInteraction};
use crate::error::{VolumeError, config};
use crate::grid::VolumeGrid;
use crate::hierarchy::{CoarseOpacity, Hierarchy};
use crate::solution::VolumeSolution;
use crate::system::{Energy, System, SystemSettings, Work};

/// Which oracles refine.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Oracle {
    /// Static only.
    Static,
    /// Dynamic only.
    Dynamic,
    /// Static first, then dynamic (the paper; default).
    #[default]
    Both,
    /// No oracle: refine every cell at every level (a coarse-to-fine standard solve).
    None,
}

/// The relaxation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Relaxation {
    /// Jacobi (GlobalCube eq. (28); default).
    #[default]
    Jacobi,
    /// Blocked Gauss–Seidel.
    GaussSeidel,
    /// GMRES(30) on `(I − K) Chi = Chi_source`; one "relaxation" is one GMRES iteration.
    Gmres,
}

/// A refinement threshold.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Threshold {
    /// `t/255` of the quantity's range (the paper's 8-bit thresholds).
    Fraction(f64),
    /// An absolute value in the quantity's unit (σ: 1; source: W/m³; faces: W).
    Absolute(f64),
}

impl Threshold {
    fn resolve(self, range: f64) -> f64 {
        match self {
            Self::Fraction(t) => t / 255.0 * range,
            Self::Absolute(v) => v,
        }
    }
    fn check(self, what: &str) -> Result<(), VolumeError> {
        let v = match self {
            Self::Fraction(t) => t,
            Self::Absolute(v) => v,
        };
        if !(v.is_finite() && v >= 0.0) {
            return Err(config(what, format!("{v} must be finite and >= 0")));
        }
        Ok(())
    }
}

/// Every knob of the method.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GlobalCubeConfig {
    /// Coarse levels `L` (`M = m0 + L`; 0 = the standard global cube). Default 2.
    pub levels: usize,
    /// Framebuffer cap `N` (1..=1024); a level-`l` receiver uses `min(N, side >> l)`.
    /// Default 32.
    pub framebuffer: usize,
    /// Static threshold on σ details.
    pub threshold_opacity: Threshold,
    /// Static threshold on `χᵗ` details.
    pub threshold_source: Threshold,
    /// Dynamic threshold on face differences.
    pub threshold_chi: Threshold,
    /// Oracles.
    pub oracle: Oracle,
    /// Relaxations per refinement step (default 1, the paper).
    pub relaxations: usize,
    /// Largest relative update (Jacobi, Gauss–Seidel) or relative residual (GMRES)
    /// at which a solve stops (default 1e-4).
    pub tolerance: f64,
    /// Iteration cap of each solve to tolerance (default 500).
    pub max_iterations: usize,
    /// Relaxation method.
    pub solver: Relaxation,
    /// Projection mode (CPU backend).
    pub projection: Projection,
    /// Γ convention.
    pub gamma: GammaMode,
    /// Collision weights.
    pub collision: Collision,
    /// Coarse opacities.
    pub coarse_opacity: CoarseOpacity,
    /// Refinement steps per level at most (default 16).
    pub max_steps: usize,
    /// Framebuffer of the escape measurement (default 8).
    pub escape_framebuffer: usize,
    /// Self-interaction of scattered light (default uniform).
    pub self_interaction: SelfInteraction,
    /// Largest recorded transport per active set, bytes (default
    /// [`crate::system::DEFAULT_TRANSPORT_MEMORY`], 1 GiB; 0 re-projects at every
    /// relaxation). The results are the same either way up to the order of
    /// floating-point sums, except with adaptive supersampling, whose pixels the
    /// recording keeps ([`crate::system`] docs).
    pub transport_memory: usize,
}

impl Default for GlobalCubeConfig {
    fn default() -> Self {
        Self {
            levels: 2,
            framebuffer: 32,
            threshold_opacity: Threshold::Fraction(33.0),
            threshold_source: Threshold::Fraction(33.0),
            threshold_chi: Threshold::Fraction(33.0),
            oracle: Oracle::Both,
            relaxations: 1,
            tolerance: 1e-4,
            max_iterations: 500,
            solver: Relaxation::Jacobi,
            projection: Projection::Exact,
            gamma: GammaMode::Normalized,
            collision: Collision::Exact,
            coarse_opacity: CoarseOpacity::Average,
            max_steps: 16,
            escape_framebuffer: 8,
            self_interaction: SelfInteraction::Uniform,
            transport_memory: crate::system::DEFAULT_TRANSPORT_MEMORY,
        }
    }
}

impl GlobalCubeConfig {
    /// The standard (non-hierarchical) global cube at framebuffer `framebuffer`, solved
    /// tightly: levels 0 (every voxel a receiver), GMRES to a relative residual of
    /// 1e-6, the escape measured at `max(framebuffer, 8)`; every other knob is the
    /// default. This is the model that `global-cube-mc` compares with Monte Carlo and
    /// the crate's `solve_cpu` example times.
    #[must_use]
    pub fn standard(framebuffer: usize) -> Self {
        Self {
            levels: 0,
            framebuffer,
            escape_framebuffer: framebuffer.max(8),
            solver: Relaxation::Gmres,
            tolerance: 1e-6,
            ..Self::default()
        }
    }

    /// Sets every threshold to the 8-bit fraction `t` (GlobalCube Fig. 10).
    #[must_use]
    pub fn with_threshold(mut self, t: f64) -> Self {
        self.threshold_opacity = Threshold::Fraction(t);
        self.threshold_source = Threshold::Fraction(t);
        self.threshold_chi = Threshold::Fraction(t);
        self
    }

    /// Checks ranges.
    ///
    /// # Errors
    /// [`VolumeError::Config`] naming the option.
    pub fn validate(&self) -> Result<(), VolumeError> {
        if self.framebuffer == 0 || self.framebuffer > crate::cubemap::MAX_FRAMEBUFFER {
            return Err(config(
                "framebuffer",
                format!("{} outside 1..=1024", self.framebuffer),
            ));
        }
        if self.escape_framebuffer == 0 || self.escape_framebuffer > crate::cubemap::MAX_FRAMEBUFFER
        {
            return Err(config(
                "escape framebuffer",
                format!("{} outside 1..=1024", self.escape_framebuffer),
            ));
        }
        self.threshold_opacity.check("threshold-opacity")?;
        self.threshold_source.check("threshold-source")?;
        self.threshold_chi.check("threshold-chi")?;
        if !(self.tolerance.is_finite() && self.tolerance > 0.0) {
            return Err(config(
                "tolerance",
                format!("{} must be finite and > 0", self.tolerance),
            ));
        }
        if self.relaxations == 0 {
            return Err(config("relaxations", "must be >= 1"));
        }
        if self.max_iterations == 0 || self.max_steps == 0 {
            return Err(config("max-iterations / max-steps", "must be >= 1"));
        }
        Ok(())
    }
}

/// One record of the solve loop (GlobalCube Table 1's rows).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct StepRecord {
    /// Level being refined into (`0` = the input voxels); the lowpass solve has `L`.
    pub level: usize,
    /// Step within the level (1-based); the final solve has step 0.
    pub step: usize,
    /// What the record is: `lowpass`, `refine` or `final`.
    pub kind: &'static str,
    /// Active cells during the step's relaxations.
    pub elements: usize,
    /// Cells refined by the static oracle before this step.
    pub static_refined: usize,
    /// Cells refined by the dynamic oracle before this step.
    pub dynamic_refined: usize,
    /// Relaxations (sweeps or GMRES iterations) in this step.
    pub relaxations: usize,
    /// Largest relative update (or GMRES relative residual) of the last relaxation.
    pub max_update: f64,
    /// Wall seconds of the step (rebuild, relaxations, oracle).
    pub seconds: f64,
    /// Energy account after the step (with the escape measurement).
    pub energy: Energy,
    /// The cells split before this step and which oracle split them (GlobalCube
    /// Fig. 14: static first, then dynamic); empty for the lowpass and final records.
    #[serde(skip)]
    pub refined: Vec<Refined>,
}

/// A cell an oracle split before a refinement step.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Refined {
    /// The cell (its level is the one refined from, `m + 1`).
    pub leaf: crate::active::Leaf,
    /// Split by the static oracle (else by the dynamic one, or by [`Oracle::None`]).
    pub by_static: bool,
}

impl Refined {
    /// The `leaves` marked in `split`, with `by_static` telling which oracle split them.
    fn list(leaves: &[crate::active::Leaf], split: &[bool], by_static: &[bool]) -> Vec<Self> {
        leaves
            .iter()
            .zip(split.iter().zip(by_static))
            .filter(|(_, (s, _))| **s)
            .map(|(l, (_, b))| Refined {
                leaf: *l,
                by_static: *b,
            })
            .collect()
    }
}

/// Solves `grid` with `config` on `projector`. `progress` is called after every
/// record (for progress bars).
///
/// # Errors
/// Invalid configuration, levels beyond `log2(side)`, backend and solver failures.
pub fn solve(
    grid: &VolumeGrid,
    cfg: &GlobalCubeConfig,
    projector: &dyn Projector,
    progress: &mut dyn FnMut(&StepRecord),
) -> Result<VolumeSolution, VolumeError> {
    solve_observed(grid, cfg, projector, progress, None)
}

/// [`solve`], handing `snapshot` the state after the lowpass solve and after each
/// refinement step as a [`VolumeSolution`] whose `steps` end with that record (the
/// final solve's state is the returned solution): the progressive images of
/// GlobalCube Figs. 13–14. Building a
/// snapshot copies the active set and its face powers (tens of bytes per cell).
///
/// # Errors
/// As [`solve`].
pub fn solve_with_snapshots(
    grid: &VolumeGrid,
    cfg: &GlobalCubeConfig,
    projector: &dyn Projector,
    snapshot: &mut dyn FnMut(VolumeSolution),
) -> Result<VolumeSolution, VolumeError> {
    solve_observed(grid, cfg, projector, &mut |_| {}, Some(snapshot))
}

fn solve_observed(
    grid: &VolumeGrid,
    cfg: &GlobalCubeConfig,
    projector: &dyn Projector,
    progress: &mut dyn FnMut(&StepRecord),
    mut snapshot: Option<&mut dyn FnMut(VolumeSolution)>,
) -> Result<VolumeSolution, VolumeError> {
    cfg.validate()?;
    let t_all = Instant::now();
    let hierarchy = Hierarchy::new(grid, cfg.levels, cfg.coarse_opacity)?;
    let settings = SystemSettings {
        collision: cfg.collision,
        gamma: cfg.gamma,
        framebuffer: cfg.framebuffer,
        escape_framebuffer: cfg.escape_framebuffer,
        self_interaction: cfg.self_interaction,
        transport_memory: cfg.transport_memory,
    };
    let mut cache = WeightCache::default();
    let mut work = Work::default();
    let mut steps = Vec::new();
    // The state as a solution (snapshots and the result).
    let solution = |sys: &System<'_>,
                    chi: Vec<FaceRgb>,
                    collided: &[FaceRgb],
                    steps: Vec<StepRecord>,
                    work: Work| {
        VolumeSolution::new(
            grid,
            *cfg,
            projector.name(),
            sys,
            chi,
            collided,
            steps,
            work,
            t_all.elapsed().as_secs_f64(),
        )
    };

    // Lowpass solve.
    let t = Instant::now();
    let set = ActiveSet::uniform(grid.side, cfg.levels);
    let mut sys = System::new(projector, settings, &hierarchy, grid.voxel, set, &mut cache);
    let mut chi = sys.sources.clone();
    let (upd, n_relax, mut collided) = solve_to_tolerance(&sys, &mut chi, cfg, &mut work)?;
    let energy = sys.energy(&chi, &collided)?;
    let rec = StepRecord {
        level: cfg.levels,
        step: 1,
        kind: "lowpass",
        elements: sys.len(),
        static_refined: 0,
        dynamic_refined: 0,
        relaxations: n_relax,
        max_update: upd,
        seconds: t.elapsed().as_secs_f64(),
        energy,
        refined: Vec::new(),
    };
    progress(&rec);
    steps.push(rec);
    if let Some(f) = snapshot.as_mut() {
        f(solution(&sys, chi.clone(), &collided, steps.clone(), work));
    }

    let thr = Thresholds::resolve(grid, cfg, &chi);
    for m in (0..cfg.levels).rev() {
        // First refinement of the level: static and/or dynamic (or everything).
        let (mut split, mut by_static, mut n_static, mut n_dynamic) =
            first_split(&sys, &hierarchy, &chi, cfg, &thr, m);
        let mut step = 0;
        while n_static + n_dynamic > 0 && step < cfg.max_steps {
            step += 1;
            let t = Instant::now();
            let refined = Refined::list(&sys.set.leaves, &split, &by_static);
            let (set, origin) = sys.set.refine(&split);
            let new_sys = System::new(projector, settings, &hierarchy, grid.voxel, set, &mut cache);
            chi = initialise(&sys, &new_sys, &origin, &chi);
            sys = new_sys;
            let mut upd = 0.0;
            let mut relax = 0;
            for _ in 0..cfg.relaxations {
                let (u, c) = relax_once(&sys, &mut chi, cfg, &mut work)?;
                upd = u;
                collided = c;
                relax += 1;
            }
            let energy = sys.energy(&chi, &collided)?;
            // Dynamic oracle on the level-(m+1) leaves left.
            split = vec![false; sys.len()];
            by_static = vec![false; sys.len()];
            let mut next_dynamic = 0;
            if matches!(cfg.oracle, Oracle::Dynamic | Oracle::Both) {
                for (i, leaf) in sys.set.leaves.iter().enumerate() {
                    if leaf.level as usize == m + 1 && dynamic_oracle(&chi[i], thr.chi) {
                        split[i] = true;
                        next_dynamic += 1;
                    }
                }
            }
            let rec = StepRecord {
                level: m,
                step,
                kind: "refine",
                elements: sys.len(),
                static_refined: n_static,
                dynamic_refined: n_dynamic,
                relaxations: relax,
                max_update: upd,
                seconds: t.elapsed().as_secs_f64(),
                energy,
                refined,
            };
            progress(&rec);
            steps.push(rec);
            if let Some(f) = snapshot.as_mut() {
                f(solution(&sys, chi.clone(), &collided, steps.clone(), work));
            }
            n_static = 0;
            n_dynamic = next_dynamic;
        }
    }

    // Final solve on the last active set.
    let t = Instant::now();
    let (upd, n_relax, c) = solve_to_tolerance(&sys, &mut chi, cfg, &mut work)?;
    collided = c;
    let energy = sys.energy(&chi, &collided)?;
    let rec = StepRecord {
        level: 0,
        step: 0,
        kind: "final",
        elements: sys.len(),
        static_refined: 0,
        dynamic_refined: 0,
        relaxations: n_relax,
        max_update: upd,
        seconds: t.elapsed().as_secs_f64(),
        energy,
        refined: Vec::new(),
    };
    progress(&rec);
    steps.push(rec);
    Ok(solution(&sys, chi, &collided, steps, work))
}

/// The oracles' thresholds in absolute units.
struct Thresholds {
    opacity: f64,
    source: f64,
    chi: f64,
}

impl Thresholds {
    /// σ and `χᵗ` over the input's range, face powers over the lowpass solution `chi`.
    fn resolve(grid: &VolumeGrid, cfg: &GlobalCubeConfig, chi: &[FaceRgb]) -> Self {
        let range = |a: &ndarray::Array3<f64>| {
            let (lo, hi) = a
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), &v| {
                    (l.min(v), h.max(v))
                });
            (hi - lo).max(0.0)
        };
        let chi_max = chi
            .iter()
            .flat_map(|f| f.iter().flat_map(|c| c.iter().copied()))
            .fold(0.0, f64::max);
        Self {
            opacity: cfg.threshold_opacity.resolve(range(&grid.opacity)),
            source: cfg
                .threshold_source
                .resolve((0..3).map(|c| range(&grid.source[c])).fold(0.0, f64::max)),
            chi: cfg.threshold_chi.resolve(chi_max),
        }
    }
}

/// The first refinement into level `m`: which level-`m + 1` leaves split, which of
/// them by the static oracle, and the static and dynamic counts.
fn first_split(
    sys: &System<'_>,
    hierarchy: &Hierarchy,
    chi: &[FaceRgb],
    cfg: &GlobalCubeConfig,
    thr: &Thresholds,
    m: usize,
) -> (Vec<bool>, Vec<bool>, usize, usize) {
    let mut split = vec![false; sys.len()];
    let mut by_static = vec![false; sys.len()];
    let (mut n_static, mut n_dynamic) = (0, 0);
    for (i, leaf) in sys.set.leaves.iter().enumerate() {
        if leaf.level as usize != m + 1 {
            continue;
        }
        let s = match cfg.oracle {
            Oracle::None => true,
            Oracle::Static | Oracle::Both => {
                static_oracle(hierarchy, leaf, thr.opacity, thr.source)
            }
            Oracle::Dynamic => false,
        };
        let d = !s
            && matches!(cfg.oracle, Oracle::Dynamic | Oracle::Both)
            && dynamic_oracle(&chi[i], thr.chi);
        split[i] = s || d;
        by_static[i] = s;
        n_static += usize::from(s);
        n_dynamic += usize::from(d);
    }
    (split, by_static, n_static, n_dynamic)
}

fn static_oracle(
    h: &Hierarchy,
    leaf: &crate::active::Leaf,
    thr_opacity: f64,
    thr_source: f64,
) -> bool {
    let (l, i) = (leaf.level as usize, leaf.zyx());
    h.max_detail_opacity[l][i] >= thr_opacity || h.max_detail_source[l][i] >= thr_source
}

fn dynamic_oracle(chi: &FaceRgb, thr: f64) -> bool {
    for c in 0..3 {
        let (lo, hi) = chi
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), f| {
                (l.min(f[c]), h.max(f[c]))
            });
        if hi - lo >= thr {
            return true;
        }
    }
    false
}

/// One relaxation of the configured kind; returns the update and collided powers.
fn relax_once(
    sys: &System<'_>,
    chi: &mut [FaceRgb],
    cfg: &GlobalCubeConfig,
    work: &mut Work,
) -> Result<(f64, Vec<FaceRgb>), VolumeError> {
    match cfg.solver {
        Relaxation::Jacobi => sys.jacobi(chi, work),
        Relaxation::GaussSeidel => sys.gauss_seidel(chi, work),
        Relaxation::Gmres => {
            let (r, _) = sys.gmres(chi, cfg.tolerance, 1, work)?;
            let (_, c) = sys.apply(chi, work)?;
            Ok((r, c))
        }
    }
}

/// Relaxes until the update (residual for GMRES) is below the tolerance; returns it,
/// the relaxations made and the collided powers of the final state.
fn solve_to_tolerance(
    sys: &System<'_>,
    chi: &mut [FaceRgb],
    cfg: &GlobalCubeConfig,
    work: &mut Work,
) -> Result<(f64, usize, Vec<FaceRgb>), VolumeError> {
    match cfg.solver {
        Relaxation::Gmres => {
            let (r, it) = sys.gmres(chi, cfg.tolerance, cfg.max_iterations, work)?;
            let (_, c) = sys.apply(chi, work)?;
            Ok((r, it, c))
        }
        _ => {
            let mut last = (f64::INFINITY, Vec::new());
            let mut n = 0;
            while n < cfg.max_iterations {
                last = relax_once(sys, chi, cfg, work)?;
                n += 1;
                if !last.0.is_finite() {
                    return Err(VolumeError::Solver(format!(
                        "relaxation diverged (update {})",
                        last.0
                    )));
                }
                if last.0 < cfg.tolerance {
                    break;
                }
            }
            if n == 0 {
                let (_, c) = sys.apply(chi, work)?;
                last.1 = c;
            }
            Ok((last.0, n, last.1))
        }
    }
}

/// Face powers of a refined set from the previous one: kept leaves keep theirs;
/// children by GlobalCube eqs. (33)–(34) (quarter of the parent face).
fn initialise(
    old: &System<'_>,
    new: &System<'_>,
    origin: &[Origin],
    chi: &[FaceRgb],
) -> Vec<FaceRgb> {
    let mut out = Vec::with_capacity(origin.len());
    for (i, o) in origin.iter().enumerate() {
        match *o {
            Origin::Kept(j) => out.push(chi[j]),
            Origin::Child { parent, octant } => {
                if new.receiver_of[i].is_none() {
                    out.push(new.sources[i]);
                    continue;
                }
                let src_c = new.sources[i];
                let src_p = old.sources[parent];
                let mut f = [[0.0; 3]; 6];
                for s in 0..6 {
                    let axis = s / 2;
                    let positive = s % 2 == 0;
                    let bit = (octant >> axis) & 1;
                    let on_boundary = (bit == 1) == positive;
                    for c in 0..3 {
                        let parent_part = (chi[parent][s][c] - src_p[s][c]) / 4.0;
                        f[s][c] = if on_boundary {
                            // Eq. (34).
                            src_c[s][c] + parent_part
                        } else {
                            // Eq. (33): through the sibling q next to it on side s.
                            let q = i - octant + (octant ^ (1 << axis));
                            let sq = new.data.opacity[q];
                            src_c[s][c] + (1.0 - sq) * parent_part + sq * new.sources[q][s][c]
                        };
                        f[s][c] = f[s][c].max(0.0);
                    }
                }
                out.push(f);
            }
        }
    }
    out
}
