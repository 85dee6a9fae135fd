//! The Virtual Mesh's linkless hierarchical shooting solver (VirtualMesh §5,
//! Algorithm 1).
//!
//! Every patch carries an element quadtree ([`tree`]) with its radiosity `B̃` and its
//! unshot residual `ΔB̃` (and the irradiance, for energy accounting), `k²` coefficients
//! per node and RGB channel, initialised to the emission (lines 1–4). While the
//! convergence rate `(E_i − E_r)/E_i` (VirtualMesh §6; `E_i` the emitted power, `E_r`
//! the power left to shoot, RGB summed) is below [`ShootConfig::convergence`]:
//!
//! - Southwell: the patch with the largest unshot power `Σ_ch ∫ΔB̃` shoots (line 6);
//! - Push/Pull-Residuals (line 7, [`twoscale`]): its residual is made consistent at all
//!   levels and the accuracy of every level is measured;
//! - HR-Transfer onto every other reflecting patch (lines 8–10, [`hr`]): the receiver
//!   is refined on the fly by a control-point oracle, the shooter shoots from the level
//!   where its representation is accurate; deposits add to `B̃` and `ΔB̃`; no link is
//!   stored, so memory is proportional to the elements;
//! - a curved patch with a concave island sees itself
//!   ([`crate::Support::sees_itself`]): it shoots onto a *decoy* (same geometry, zero
//!   levels) whose levels, residuals and subdivisions are copied back (§5.3); planar
//!   patches and convex sides never self-shoot;
//! - the shooter's residual is set to zero (line 12).
//!
//! Energy: every shot moves power `P = ∫ΔB̃_i`; the part arriving at reflecting
//! receivers `∫H` is split into reflected `ρ∫H` (added to the residuals) and absorbed
//! `(1 − ρ)∫H`; the rest (`P − ∫H`: open scenes, back sides, black receivers, which
//! are not shot onto, and quadrature error) is the operator's loss
//! ([`Energy::operator_loss`]), so `emitted = absorbed + unshot + operator_loss` holds
//! after every shot by construction. The escaped power itself is measured by rays from
//! the shot radiosity `B̃ − ΔB̃` ([`crate::escape`]), independently of the transfers.
//!
//! The oracle threshold [`ShootConfig::eps`] is relative. The errors of successive
//! shots add up, and with a fixed absolute tolerance the many weak late shots, all
//! accepted on coarse elements with the same sign of error (e.g. irradiance from an
//! adjacent face concentrated at the shared edge), bias the result by an amount that
//! hardly shrinks with `eps` (seen in the white furnace). So the tolerance on the RMS
//! radiosity error of an element's share of shot `s` is `eps · B̄ · P_s / E_i`, with
//! `P_s` the shot's power, `E_i` the emitted power and `B̄` the scene's mean exitance
//! (emitted power of the brightest channel over the area of all patches, W/m²): the
//! tolerances of all shots sum to `eps · B̄ · Σ P_s / E_i ≤ eps · B̄ / (1 − ρ_max)`.
//! A weak shot is thus refined as finely, relative to its size, as a strong one.
//!
//! Statistics: `elements`/`leaves` of all trees, `links = 0`, `shots`,
//! `shooting_surfaces`, `shot_convergence`, `oracle_evals` (receiver and shooter
//! decisions), `kernel_evals` and `rays` of every transfer block, `bytes` (trees,
//! compiled hierarchy and the solution's vectors), `time_setup` (supports,
//! accelerator, rules), `time_solve` (the shooting loop, refinement included;
//! `time_refine` stays zero).
//!
//! The result is a [`Solution`] like the gathering solver's: its
//! [`crate::System`] holds a [`crate::Hierarchy`] compiled from the element trees with
//! zero links, so rendering, averages and exports work unchanged.

pub mod hr;
#[cfg(test)]
mod tests;
pub mod tree;
pub mod twoscale;

use std::collections::BTreeSet;
use std::time::{Duration, Instant};

use rayon::prelude::*;
use wavelux_scene::Scene;

use crate::basis::{BasisKind, TreeBasis};
use crate::error::SolverError;
use crate::hierarchy::{Hierarchy, NodeKey, Oracle, SplitPolicy};
use crate::solution::{Energy, Solution, Statistics};
use crate::support::Patch;
use crate::system::System;
use crate::transfer::Visibility;
use crate::{LinearMethod, ParamKind, Prepared, SolverConfig};
use hr::{Counts, Params, Transfer};
use tree::{Shooter, Tree};
use twoscale::TwoScale;

/// How push/pull coefficients are obtained (VirtualMesh §5.2, Table 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum PushPull {
    /// The level-independent two-scale matrices, precomputed once (valid because
    /// equal-area maps have a constant Jacobian).
    Precomputed,
    /// Recomputed per element and level from Gram matrices integrated with a
    /// `gauss × gauss` Gauss–Legendre rule per child cell, weighted by the support's
    /// Jacobian (the natural-coordinates variant; stored per element).
    Natural {
        /// Gauss points per axis, `1..=32`.
        gauss: usize,
    },
}

/// Configuration of [`shoot`]. `Default`: Haar, `eps = 1e-2`, 6 levels, 3 Gauss points
/// per axis, automatic control depth, 99 % convergence, at most 10 000 shots, precomputed
/// push/pull, visibility in quadrature.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShootConfig {
    /// Basis (Haar, `M_2`, `M_3`, … tree bases).
    pub basis: BasisKind,
    /// Relative oracle threshold: a receiver element is refined when the RMS radiosity
    /// error of its share of a shot exceeds `eps · B̄ · P_s / E_i` (`B̄` the scene's mean
    /// exitance, `P_s / E_i` the shot's share of the emitted power; see the module
    /// docs). Finite, `> 0`.
    pub eps: f64,
    /// Deepest element level (`≤ 20`).
    pub max_level: u8,
    /// Smallest element area (scene units², finite, `≥ 0`).
    pub min_area: f64,
    /// Gauss points per axis of the transfer blocks (`1..=16`).
    pub quad_points: usize,
    /// Order of the singular rules for touching elements (`1..=8`).
    pub singular_order: usize,
    /// Admissibility factor of the regular rule (finite, `≥ 0.5`).
    pub near_field: f64,
    /// Maximum recursive quadrature splits of near pairs (`≤ 8`).
    pub max_split_depth: u32,
    /// Visibility in the transfer blocks.
    pub visibility: Visibility,
    /// Control points of the oracle: the receiver is compared on the `2^d × 2^d`
    /// control cells `control_depth = d` levels below it (`0..=3`; `0` = automatic:
    /// 2 for Haar, whose single function per cell cannot show the variation inside
    /// equal children, e.g. under a centred emitter; 1 for `M_k`, `k ≥ 2`).
    pub control_depth: u8,
    /// Target convergence rate `(E_i − E_r)/E_i` in `(0, 1]`: shooting stops once it is
    /// reached.
    pub convergence: f64,
    /// Maximum number of shots (`≥ 1`).
    pub max_shots: usize,
    /// Push/pull variant.
    pub push_pull: PushPull,
}

impl Default for ShootConfig {
    fn default() -> Self {
        Self {
            basis: BasisKind::Haar,
            eps: 1e-2,
            max_level: 6,
            min_area: 0.0,
            quad_points: 3,
            singular_order: 4,
            near_field: 1.0,
            max_split_depth: 3,
            visibility: Visibility::InQuadrature,
            control_depth: 0,
            convergence: 0.99,
            max_shots: 10_000,
            push_pull: PushPull::Precomputed,
        }
    }
}

fn bad(field: &'static str, value: impl std::fmt::Display, reason: &'static str) -> SolverError {
    SolverError::InvalidConfig {
        field,
        value: value.to_string(),
        reason,
    }
}

impl ShootConfig {
    /// Checks every field against its documented range: the fields shared with
    /// [`SolverConfig`] by [`SolverConfig::validate`] (one check for both solvers), the
    /// shooting ones here.
    ///
    /// # Errors
    /// [`SolverError::InvalidConfig`] naming the first bad field.
    pub fn validate(&self) -> Result<(), SolverError> {
        self.solver_config().validate()?;
        if self.control_depth > 3 {
            return Err(bad("control_depth", self.control_depth, "must be in 0..=3"));
        }
        if !(self.convergence.is_finite() && self.convergence > 0.0 && self.convergence <= 1.0) {
            return Err(bad("convergence", self.convergence, "must be in (0, 1]"));
        }
        if self.max_shots == 0 {
            return Err(bad("max_shots", 0, "must be >= 1"));
        }
        if let PushPull::Natural { gauss } = self.push_pull
            && !(1..=32).contains(&gauss)
        {
            return Err(bad("push_pull.gauss", gauss, "must be in 1..=32"));
        }
        Ok(())
    }

    /// The gathering configuration sharing this one's discretisation (used to prepare
    /// patches, accelerator and transfer context).
    pub fn solver_config(&self) -> SolverConfig {
        SolverConfig {
            basis: self.basis,
            eps: self.eps,
            max_level: self.max_level,
            min_area: self.min_area,
            oracle: Oracle::KernelSmoothness,
            split: SplitPolicy::Both,
            visibility: self.visibility,
            oracle_visibility: true,
            quad_points: self.quad_points,
            singular_order: self.singular_order,
            near_field: self.near_field,
            max_split_depth: self.max_split_depth,
            linear_method: LinearMethod::Picard,
            max_iterations: 1,
            tolerance: 0.0,
            multigrid: None,
            ..SolverConfig::default()
        }
    }
}

/// Shoots a scene (see the module docs): equal-area supports with
/// [`PushPull::Precomputed`], natural-coordinate curved supports with
/// [`PushPull::Natural`] (VirtualMesh Table 3's two variants).
///
/// # Errors
/// [`SolverError`] for an invalid configuration or scene and unsupported surfaces or
/// bases.
pub fn shoot(scene: &Scene, config: &ShootConfig) -> Result<Solution, SolverError> {
    config.validate()?;
    let kind = match config.push_pull {
        PushPull::Natural { .. } => ParamKind::Natural,
        _ => ParamKind::EqualArea,
    };
    let prep = Prepared::with_kind(scene, &config.solver_config(), kind)?;
    shoot_prepared(&prep, config)
}

/// [`shoot`] on a prepared scene (its patches, accelerator and basis; the transfer
/// options come from `config`).
///
/// # Errors
/// As [`shoot`]; [`SolverError::InvalidConfig`] if `config.basis` differs from the
/// prepared basis.
pub fn shoot_prepared(prep: &Prepared, config: &ShootConfig) -> Result<Solution, SolverError> {
    check_prepared(prep, config)?;
    let t0 = Instant::now();
    let patches = &prep.patches.patches;
    let ctx = crate::TransferCtx::new(
        patches,
        &prep.accel,
        prep.frame,
        &prep.basis,
        config.solver_config().transfer_options(),
    )?;
    let ts = TwoScale::new(config.push_pull, &prep.basis, patches)?;
    let mut trees = initial_trees(patches, &prep.basis, &ts);
    let mut unshot: Vec<[f64; 3]> = trees.iter().map(|t| t.integral(&t.db)).collect();
    // Emitted power: E × real area (exact for equal-area maps).
    let mut emitted = [0.0; 3];
    for u in &unshot {
        for ch in 0..3 {
            emitted[ch] += u[ch];
        }
    }
    // The scene's mean exitance (W/m²): emitted power over the real area of all
    // patches.
    let total_area: f64 = patches.iter().map(|p| p.support.real_area()).sum();
    let b_ref = emitted.iter().fold(0.0f64, |a, &b| a.max(b)) / total_area;
    let params = Params {
        tol: config.eps * b_ref,
        max_level: config.max_level,
        min_area: config.min_area,
        control_depth: match config.control_depth {
            0 if prep.basis.k() == 1 => 2,
            0 => 1,
            d => d,
        },
    };
    let shots = Shots::run(
        &ctx,
        &ts,
        params,
        config,
        emitted.iter().sum(),
        &mut trees,
        &mut unshot,
    );
    Ok(assemble(prep, &ctx, &ts, &trees, emitted, shots, t0))
}

/// The checks [`shoot_prepared`] adds to [`ShootConfig::validate`]: the prepared basis
/// and, for precomputed push/pull, equal-area supports.
fn check_prepared(prep: &Prepared, config: &ShootConfig) -> Result<(), SolverError> {
    config.validate()?;
    if prep.basis.kind() != config.basis {
        return Err(bad(
            "basis",
            config.basis.name(),
            "must equal the prepared basis",
        ));
    }
    if config.push_pull == PushPull::Precomputed
        && !prep
            .patches
            .patches
            .iter()
            .all(|p| p.support.is_equal_area())
    {
        return Err(bad(
            "push_pull",
            "Precomputed",
            "precomputed push/pull needs equal-area supports (constant Jacobian, VirtualMesh §5.2); use Natural",
        ));
    }
    Ok(())
}

/// Algorithm 1, lines 1–4: one element tree per patch with `B̃ = ΔB̃ = Ẽ` at the root.
fn initial_trees(patches: &[Patch], basis: &TreeBasis, ts: &TwoScale<'_>) -> Vec<Tree> {
    let n = basis.n();
    let mut trees: Vec<Tree> = (0..patches.len()).map(|p| Tree::new(p, ts)).collect();
    for (p, tree) in trees.iter_mut().enumerate() {
        let e = patches[p].emission;
        let sq = patches[p].support.area.sqrt();
        for ch in 0..3 {
            for a in 0..n {
                // The constant E has coefficients E √A ∫ψ_a (ψ_0 ≡ 1) on the whole
                // support; only its real points emit (the moments are real moments).
                let v = e[ch] * sq * basis.integrals()[a];
                tree.b[ch * n + a] = v;
                tree.db[ch * n + a] = v;
            }
        }
    }
    trees
}

/// What the shooting loop (Algorithm 1, lines 5–13) did.
struct Shots {
    /// Power shot minus power arriving at reflecting receivers, per channel (the
    /// operator's loss, [`Energy::operator_loss`]).
    lost: [f64; 3],
    /// Oracle and block counts.
    counts: Counts,
    /// Input primitives that shot.
    shooters: BTreeSet<u32>,
    /// Convergence rate after each shot.
    record: Vec<f64>,
    /// Wall time of the loop.
    time: Duration,
}

impl Shots {
    /// Shoots until the convergence rate reaches `config.convergence` or
    /// `config.max_shots` shots were made; `e_i` is the emitted power (RGB summed).
    fn run(
        ctx: &crate::TransferCtx<'_>,
        ts: &TwoScale<'_>,
        params: Params,
        config: &ShootConfig,
        e_i: f64,
        trees: &mut [Tree],
        unshot: &mut [[f64; 3]],
    ) -> Self {
        let patches = ctx.patches;
        let np = patches.len();
        // Curved supports with a concave island see themselves (VirtualMesh §5.3).
        let sees_itself: Vec<bool> = patches.iter().map(|p| p.support.sees_itself()).collect();
        let mut out = Self {
            lost: [0.0; 3],
            counts: Counts::default(),
            shooters: BTreeSet::new(),
            record: Vec::new(),
            time: Duration::ZERO,
        };
        let t_shoot = Instant::now();
        while e_i > 0.0 && out.record.len() < config.max_shots {
            let e_r: f64 = unshot.iter().flatten().sum();
            if (e_i - e_r) / e_i >= config.convergence {
                break;
            }
            // Line 6: Southwell (ties: lowest index).
            let mut best = None;
            let mut best_p = 0.0;
            for (p, u) in unshot.iter().enumerate() {
                let s: f64 = u.iter().sum();
                if s > best_p {
                    best_p = s;
                    best = Some(p);
                }
            }
            let Some(i) = best else { break };
            // Line 7: Push/Pull-Residuals; the shooter tree leaves its slot, which a
            // decoy takes when the patch sees itself.
            let mut own = std::mem::take(&mut trees[i]);
            let power = own.integral(&own.db);
            let self_shot = sees_itself[i] && patches[i].reflects();
            if self_shot {
                trees[i] = Tree::new(i, ts);
            }
            // Per-shot tolerance in proportion to the shot's share of the emitted power.
            let share = power.iter().sum::<f64>() / e_i;
            let p = Params {
                tol: params.tol * share,
                ..params
            };
            let (arr, refl, cnt) = shoot_once(ctx, ts, p, &own, i, self_shot, trees);
            out.counts.add(&cnt);
            // Line 12, then the decoy's levels, residuals and subdivisions come back.
            own.clear_unshot();
            unshot[i] = [0.0; 3];
            if self_shot {
                let decoy = std::mem::take(&mut trees[i]);
                own.absorb(&decoy, ts);
            }
            trees[i] = own;
            for ch in 0..3 {
                let mut got = 0.0;
                for j in 0..np {
                    got += arr[j][ch];
                    unshot[j][ch] += refl[j][ch];
                }
                out.lost[ch] += power[ch] - got;
            }
            out.shooters.insert(patches[i].prim);
            let e_r: f64 = unshot.iter().flatten().sum();
            out.record.push((e_i - e_r) / e_i);
        }
        out.time = t_shoot.elapsed();
        out
    }
}

/// Power arriving at and reflected by each patch, per channel, and the counts of a
/// shot.
type ShotResult = (Vec<[f64; 3]>, Vec<[f64; 3]>, Counts);

/// Algorithm 1, lines 8–11: HR-Transfer of patch `i`'s residual (`own`) onto every
/// other reflecting patch (onto its decoy in `trees[i]` when `self_shot`); receivers in
/// parallel, sums in patch order.
fn shoot_once(
    ctx: &crate::TransferCtx<'_>,
    ts: &TwoScale<'_>,
    p: Params,
    own: &Tree,
    i: usize,
    self_shot: bool,
    trees: &mut [Tree],
) -> ShotResult {
    let patches = ctx.patches;
    let shooter = Shooter::new(own, ts);
    let tr = Transfer {
        ctx,
        ts,
        shooter: &shooter,
        p,
    };
    let parts: Vec<([f64; 3], [f64; 3], Counts)> = trees
        .par_iter_mut()
        .enumerate()
        .map(|(j, t)| {
            if (j == i && !self_shot) || !patches[j].reflects() {
                return ([0.0; 3], [0.0; 3], Counts::default());
            }
            let (deps, c) = tr.run(j);
            let mut arr = [0.0; 3];
            let mut refl = [0.0; 3];
            for d in deps {
                let (a, r) = t.deposit(d.key, &d.h, patches[j].reflectance, ts);
                for ch in 0..3 {
                    arr[ch] += a[ch];
                    refl[ch] += r[ch];
                }
            }
            (arr, refl, c)
        })
        .collect();
    let np = patches.len();
    let mut arr = vec![[0.0; 3]; np];
    let mut refl = vec![[0.0; 3]; np];
    let mut cnt = Counts::default();
    for (j, (a, r, c)) in parts.into_iter().enumerate() {
        arr[j] = a;
        refl[j] = r;
        cnt.add(&c);
    }
    (arr, refl, cnt)
}

/// The output of a shooting run: a linkless hierarchy over all element trees, the
/// consistent coefficients at every node, the energy account (absorbed and unshot
/// from the trees, escape measured by rays) and the statistics.
fn assemble(
    prep: &Prepared,
    ctx: &crate::TransferCtx<'_>,
    ts: &TwoScale<'_>,
    trees: &[Tree],
    emitted: [f64; 3],
    shots: Shots,
    t0: Instant,
) -> Solution {
    let patches = &prep.patches.patches;
    let n = prep.basis.n();
    let np = patches.len();
    let keys: Vec<NodeKey> = trees.iter().flat_map(|t| t.keys.iter().copied()).collect();
    let h = Hierarchy::compile_with_nodes(n, np, &keys, &[]);
    let system = System::new(h, &prep.basis, patches);
    let nn = system.h.node_count();
    let mut node_b: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; nn * n]);
    let mut leaf_h: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; system.dim()]);
    let mut energy = Energy {
        emitted,
        operator_loss: shots.lost,
        ..Energy::default()
    };
    // The shot radiosity B̃ − ΔB̃ at every node, for the escape measurement.
    let mut node_shot: [Vec<f64>; 3] = std::array::from_fn(|_| vec![0.0; nn * n]);
    let mut tree_bytes = 0;
    for t in trees {
        tree_bytes += t.bytes();
        let b = t.consistent(&t.b, ts);
        let db = t.consistent(&t.db, ts);
        let hc = t.consistent(&t.h, ts);
        let un = t.integral(&t.db);
        let ih = t.integral(&t.h);
        let rho = patches[t.keys[0].patch as usize].reflectance;
        for ch in 0..3 {
            energy.unshot[ch] += un[ch];
            energy.absorbed[ch] += (1.0 - rho[ch]) * ih[ch];
        }
        for (k, key) in t.keys.iter().enumerate() {
            let Ok(g) = system.h.keys.binary_search(key) else {
                continue;
            };
            let leaf = system.h.leaf_of[g];
            for ch in 0..3 {
                node_b[ch][g * n..][..n].copy_from_slice(&b[(k * 3 + ch) * n..][..n]);
                for a in 0..n {
                    let idx = (k * 3 + ch) * n + a;
                    node_shot[ch][g * n + a] = b[idx] - db[idx];
                }
                if leaf != u32::MAX {
                    leaf_h[ch][leaf as usize * n..][..n]
                        .copy_from_slice(&hc[(k * 3 + ch) * n..][..n]);
                }
            }
        }
    }
    let [cells_empty, cells_partial, cells_full] = system.coverage_counts;
    let time_shoot = shots.time;
    let stats = Statistics {
        elements: nn,
        leaves: system.h.leaves.len(),
        links: 0,
        oracle_evals: shots.counts.oracle_evals,
        kernel_evals: ctx.kernel_evals.load(std::sync::atomic::Ordering::Relaxed),
        rays: ctx.rays.load(std::sync::atomic::Ordering::Relaxed),
        bytes: tree_bytes + system.h.bytes(),
        time_setup: prep.setup_time + t0.elapsed().saturating_sub(time_shoot),
        time_solve: time_shoot,
        iterations: vec![shots.record.len()],
        stages: 1,
        shots: shots.record.len(),
        shooting_surfaces: shots.shooters.len(),
        shot_convergence: shots.record,
        cells_empty,
        cells_partial,
        cells_full,
        ..Statistics::default()
    };
    let esc = crate::escape::measure(prep, &system.h, &|p, s, t| {
        crate::solution::eval_nodes(&system, &prep.basis, &node_shot, p, s, t)
    });
    let mut sol = Solution::from_parts(
        patches.clone(),
        prep.patches.by_surface.clone(),
        system,
        prep.basis.clone(),
        node_b,
        leaf_h,
        energy,
        stats,
        Vec::new(),
    );
    sol.set_escape(esc);
    sol
}
