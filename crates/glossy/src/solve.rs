//! Solving `L = L_e + T L` and `Γ = Γ_e + T Γ` on the current links (Glossy §5.1):
//! Gauss–Seidel over receiving patches (the paper's choice), Picard (Jacobi) or
//! GMRES (wavelux-linear, one solve per band).
//!
//! The standard decomposition needs no push/pull: a link adds `T[τ]·x_sender` to the
//! receiving node's wavelet `τ` (or to the root `φ`), whatever the two levels. Every
//! method is independent of the thread count: Picard computes each patch from the
//! previous iterate in parallel and writes disjoint slots; Gauss–Seidel runs patches
//! in index order; GMRES applies the same Picard product.

use rayon::prelude::*;
use wavelux_linear::{FnOperator, SolverOptions, gmres};

use crate::error::{GlossyError, dep};
use crate::link::LinkSet;
use crate::tree::{BANDS, Functions};

/// The linear solver.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub enum LinearSolver {
    /// Block Gauss–Seidel over receiving patches (Glossy §5.1).
    #[default]
    GaussSeidel,
    /// Picard / Jacobi: `x ← e + T x`.
    Picard,
    /// Restarted GMRES(30) on `(I − T) x = e`, per band.
    Gmres,
}

impl LinearSolver {
    /// Lower-case name.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::GaussSeidel => "gauss-seidel",
            Self::Picard => "picard",
            Self::Gmres => "gmres",
        }
    }
}

/// Record of one solve.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize)]
pub struct SolveRecord {
    /// Sweeps (Gauss–Seidel, Picard) or operator applications (GMRES, all bands).
    pub iterations: usize,
    /// Last relative change `‖x_k − x_{k−1}‖₂/‖x_k‖₂` (largest band), or GMRES's
    /// relative residual.
    pub change: f64,
    /// Whether `change ≤ tolerance`.
    pub converged: bool,
}

/// `y_p = e_p + Σ_{links into p} T x` for the functions of patch `p`, written into the
/// `slots` of `y` (global ids), for the bands in `bands`.
fn gather_patch(
    funcs: &Functions,
    links: &LinkSet,
    p: usize,
    x: &[[f64; BANDS]],
    bands: std::ops::Range<usize>,
    out: &mut Vec<(u32, [f64; BANDS])>,
) {
    out.clear();
    let tree = &funcs.trees[p];
    // Local accumulation: root φ then nodes' 15 wavelets, in id order.
    let nfun = 1 + 15 * tree.len();
    let mut acc = vec![[0.0; BANDS]; nfun];
    let local = |id: u32| -> usize {
        if id == tree.root_phi {
            0
        } else {
            let r = funcs.owner[id as usize];
            1 + 15 * r.node as usize + r.tau as usize - 1
        }
    };
    for id in tree.ids() {
        let e = &funcs.emit[id as usize];
        let a = &mut acc[local(id)];
        for b in bands.clone() {
            a[b] = e[b];
        }
    }
    if let Some(range) = links.ranges.get(p) {
        for l in &links.links[range.clone()] {
            let xs = &x[l.sender as usize];
            if l.recv_phi {
                let a = &mut acc[0];
                for b in bands.clone() {
                    a[b] += f64::from(l.coef[b % 3][0]) * xs[b];
                }
            } else {
                let base = 1 + 15 * l.recv_node as usize;
                for t in 0..15 {
                    let a = &mut acc[base + t];
                    for b in bands.clone() {
                        a[b] += f64::from(l.coef[b % 3][t]) * xs[b];
                    }
                }
            }
        }
    }
    for id in tree.ids() {
        out.push((id, acc[local(id)]));
    }
}

pub(crate) fn rel_change(
    old: &[[f64; BANDS]],
    new: &[[f64; BANDS]],
    bands: std::ops::Range<usize>,
) -> f64 {
    let mut worst: f64 = 0.0;
    for b in bands {
        let (mut d, mut n) = (0.0, 0.0);
        for (o, v) in old.iter().zip(new) {
            d += (v[b] - o[b]).powi(2);
            n += v[b] * v[b];
        }
        let r = if n > 0.0 {
            (d / n).sqrt()
        } else if d > 0.0 {
            f64::INFINITY
        } else {
            0.0
        };
        worst = worst.max(r);
    }
    worst
}

/// One Picard product `y = e + T x` over all patches (parallel, deterministic).
pub fn picard_step(
    funcs: &Functions,
    links: &LinkSet,
    x: &[[f64; BANDS]],
    bands: std::ops::Range<usize>,
) -> Vec<[f64; BANDS]> {
    let parts: Vec<Vec<(u32, [f64; BANDS])>> = (0..funcs.trees.len())
        .into_par_iter()
        .map(|p| {
            let mut out = Vec::new();
            gather_patch(funcs, links, p, x, bands.clone(), &mut out);
            out
        })
        .collect();
    let mut y = x.to_vec();
    for part in parts {
        for (id, v) in part {
            for b in bands.clone() {
                y[id as usize][b] = v[b];
            }
        }
    }
    y
}

/// Solves for the bands `bands` (starting from the current values) until the relative
/// change falls below `tolerance` or `max_iterations` sweeps.
///
/// # Errors
/// [`GlossyError::NonFinite`] if the iteration produces a non-finite value (a
/// divergent system, e.g. an albedo above 1); [`GlossyError::Dependency`] for GMRES
/// input errors.
pub fn solve(
    funcs: &mut Functions,
    links: &LinkSet,
    bands: std::ops::Range<usize>,
    solver: LinearSolver,
    tolerance: f64,
    max_iterations: usize,
) -> Result<SolveRecord, GlossyError> {
    let mut rec = SolveRecord::default();
    match solver {
        LinearSolver::Picard => {
            for it in 0..max_iterations {
                let y = picard_step(funcs, links, &funcs.value, bands.clone());
                rec.change = rel_change(&funcs.value, &y, bands.clone());
                funcs.value = y;
                rec.iterations = it + 1;
                check_finite(&rec)?;
                if rec.change <= tolerance {
                    rec.converged = true;
                    break;
                }
            }
        }
        LinearSolver::GaussSeidel => {
            let mut out = Vec::new();
            for it in 0..max_iterations {
                let old = funcs.value.clone();
                for p in 0..funcs.trees.len() {
                    gather_patch(funcs, links, p, &funcs.value, bands.clone(), &mut out);
                    for (id, v) in &out {
                        for b in bands.clone() {
                            funcs.value[*id as usize][b] = v[b];
                        }
                    }
                }
                rec.change = rel_change(&old, &funcs.value, bands.clone());
                rec.iterations = it + 1;
                check_finite(&rec)?;
                if rec.change <= tolerance {
                    rec.converged = true;
                    break;
                }
            }
        }
        LinearSolver::Gmres => {
            let n = funcs.len();
            let mut worst: f64 = 0.0;
            let mut converged = true;
            for b in bands.clone() {
                let mut rhs = vec![0.0; n];
                for (i, e) in funcs.emit.iter().enumerate() {
                    rhs[i] = e[b];
                }
                let f: &Functions = funcs;
                let op = FnOperator::new(n, |x: &[f64], y: &mut [f64]| {
                    let mut xb = vec![[0.0; BANDS]; n];
                    for (i, v) in x.iter().enumerate() {
                        xb[i][b] = *v;
                    }
                    // (I − T) x = x − (e + T x − e).
                    let tx = picard_step(f, links, &xb, b..b + 1);
                    for i in 0..n {
                        y[i] = x[i] - (tx[i][b] - f.emit[i][b]);
                    }
                });
                let x0: Vec<f64> = funcs.value.iter().map(|v| v[b]).collect();
                let opts = SolverOptions::default()
                    .with_tolerance(tolerance)
                    .with_max_iterations(max_iterations)
                    .with_initial_guess(x0);
                let s = gmres(&op, &rhs, &opts).map_err(dep("linear"))?;
                rec.iterations += s.history.work().applications as usize;
                worst = worst.max(s.history.final_relative_residual);
                converged &= s.history.converged;
                for (i, v) in s.x.iter().enumerate() {
                    funcs.value[i][b] = *v;
                }
            }
            rec.change = worst;
            rec.converged = converged;
            check_finite(&rec)?;
        }
    }
    if funcs.value.iter().any(|v| v.iter().any(|x| !x.is_finite())) {
        return Err(GlossyError::NonFinite {
            what: "solution coefficient",
            value: f64::NAN,
        });
    }
    Ok(rec)
}

pub(crate) fn check_finite(rec: &SolveRecord) -> Result<(), GlossyError> {
    if rec.change.is_finite() || rec.change == f64::INFINITY && rec.iterations == 1 {
        Ok(())
    } else {
        Err(GlossyError::NonFinite {
            what: "solver change",
            value: rec.change,
        })
    }
}
