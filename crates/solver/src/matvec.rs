//! The linear solve's link products on a matrix–vector backend (issue 17 (b), "Users:
//! the non-standard gather"; the operator `K = ρ P_down L P_up` of Ziegler §3.3,
//! [`System::irradiance`]).
//!
//! The gather `L` (every link's `n × n` block times its emitter's coefficients, summed
//! per receiver node) is a block-sparse matrix over the node vector: block row `R`
//! holds the blocks of the links into `R` at block columns of their emitters, in the
//! hierarchy's link order ([`gather_matrix`]). A backend prepares it once per solve;
//! pull (`P_up`), push (`P_down`) and the reflectance stay on the CPU ([`DeviceK`]).
//!
//! The device's products meet `wavelux_linear::backend`'s contract (`1e-6·(|A||x|)`
//! per row), not f64 rounding. The solve therefore ends with iterative refinement in
//! f64 ([`solve_refined`]): the residual `b + K x − x` of the device's solution is
//! recomputed with the f64 operator; while it misses the tolerance (at most
//! [`REFINEMENT_ROUNDS`] rounds) the correction equation `(I − K) d = r` is solved on
//! the device and `x += d`. The convergence record reports that f64 residual.

use wavelux_linear::backend::{BackendOperator, Bsr, Matrix};
use wavelux_linear::{Convergence, Operator, StopReason, Unsupported};

use crate::error::SolverError;
use crate::hierarchy::Hierarchy;
use crate::system::System;
use crate::{LinearMethod, linear_solve};

/// Most iterative-refinement rounds after the device's solve.
pub const REFINEMENT_ROUNDS: usize = 5;

/// The gather `L` of a hierarchy as a block-sparse matrix over the node vector
/// (module docs).
///
/// # Errors
/// [`SolverError::Linear`] if the blocks do not form a valid matrix (a block larger
/// than 16 × 16, non-finite entries).
pub fn gather_matrix(h: &Hierarchy) -> Result<Matrix, SolverError> {
    let nodes = h.node_count();
    Bsr::new(
        (h.n, h.n),
        (nodes, nodes),
        h.recv_offsets.clone(),
        h.link_emitter.iter().map(|&e| e as usize).collect(),
        h.blocks.clone(),
    )
    .map(Matrix::BlockSparse)
    .map_err(|e| SolverError::Linear(e.to_string()))
}

/// `K` of one channel with the gather on a prepared device matrix
/// ([`gather_matrix`]); pull, push and reflectance on the CPU. A device error puts
/// NaN in the product ([`BackendOperator`]) and is kept there.
#[derive(Debug)]
pub struct DeviceK<'s> {
    sys: &'s System,
    ch: usize,
    gather: &'s BackendOperator<'s>,
}

impl<'s> DeviceK<'s> {
    /// `K` of channel `ch` of `sys` with the gather `gather` (prepared from
    /// [`gather_matrix`] of `sys`'s hierarchy).
    pub fn new(sys: &'s System, ch: usize, gather: &'s BackendOperator<'s>) -> Self {
        Self { sys, ch, gather }
    }

    /// `P_down op(P_up v)` read at the leaves.
    fn through(&self, v: &[f64], transpose: bool) -> Vec<f64> {
        let h = self.sys.hierarchy();
        let n = h.n;
        let nn = h.node_count() * n;
        let mut b = vec![0.0; nn];
        self.sys.pull_from_leaves(v, &mut b);
        let mut g = vec![0.0; nn];
        if transpose {
            // BackendOperator's transpose never reports `Unsupported`.
            let _ = self.gather.apply_transpose(&b, &mut g);
        } else {
            self.gather.apply(&b, &mut g);
        }
        self.sys.push(&mut g);
        let mut y = vec![0.0; self.sys.dim()];
        for (l, &i) in h.leaves.iter().enumerate() {
            y[l * n..][..n].copy_from_slice(&g[i as usize * n..][..n]);
        }
        y
    }
}

impl Operator for DeviceK<'_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }

    fn apply(&self, x: &[f64], y: &mut [f64]) {
        let hv = self.through(x, false);
        let n = self.sys.hierarchy().n;
        for (l, rho) in self.sys.leaf_rho.iter().enumerate() {
            for a in 0..n {
                y[l * n + a] = rho[self.ch] * hv[l * n + a];
            }
        }
    }

    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        let n = self.sys.hierarchy().n;
        let mut rx = vec![0.0; self.sys.dim()];
        for (l, rho) in self.sys.leaf_rho.iter().enumerate() {
            for a in 0..n {
                rx[l * n + a] = rho[self.ch] * x[l * n + a];
            }
        }
        y.copy_from_slice(&self.through(&rx, true));
        Ok(())
    }
}

fn norm(v: &[f64]) -> f64 {
    v.iter().map(|x| x * x).sum::<f64>().sqrt()
}

/// `b + K x − x` with the f64 operator `k`.
fn residual<K: Operator>(k: &K, b: &[f64], x: &[f64]) -> Vec<f64> {
    let mut kx = vec![0.0; x.len()];
    k.apply(x, &mut kx);
    (0..x.len()).map(|i| b[i] + kx[i] - x[i]).collect()
}

/// Solves `x = b + K x` with the device operator `dev` and refines the solution in
/// f64 against `k` (module docs): at most [`REFINEMENT_ROUNDS`] corrections, each a
/// device solve of `(I − K) d = r`. The history holds the first solve's records,
/// then one record per refinement round with the f64 residual; its
/// `final_relative_residual` is the f64 one, and `converged` says whether it met
/// `tolerance`.
///
/// # Errors
/// [`SolverError::Linear`] if a device solve fails (a device error shows as a
/// non-finite iterate).
pub fn solve_refined<K: Operator, D: Operator>(
    k: &K,
    dev: &D,
    b: &[f64],
    method: LinearMethod,
    max_iterations: usize,
    tolerance: f64,
    x0: Option<Vec<f64>>,
) -> Result<(Vec<f64>, Convergence), SolverError> {
    let no_sweep = |_: &[f64], _: &mut [f64]| {};
    let (mut x, mut conv) = linear_solve(
        dev,
        b,
        method,
        max_iterations,
        tolerance,
        x0,
        None,
        &no_sweep,
    )?;
    let bn = match norm(b) {
        v if v > 0.0 => v,
        _ => 1.0,
    };
    let mut r = residual(k, b, &x);
    let mut rel = norm(&r) / bn;
    let mut it = conv.iterations.last().map_or(0, |l| l.iteration);
    for _ in 0..REFINEMENT_ROUNDS {
        if rel <= tolerance || !rel.is_finite() {
            break;
        }
        let rn = norm(&r);
        // The correction needs `tolerance·‖b‖` absolute, i.e. relative to `‖r‖`.
        let (d, c) = linear_solve(
            dev,
            &r,
            method,
            max_iterations,
            (tolerance * bn / rn).min(0.5),
            Some(vec![0.0; x.len()]),
            None,
            &no_sweep,
        )?;
        x.iter_mut().zip(&d).for_each(|(a, b)| *a += b);
        r = residual(k, b, &x);
        rel = norm(&r) / bn;
        it += c.iterations.last().map_or(0, |l| l.iteration);
        let last = conv.iterations.last().cloned();
        if let Some(mut rec) = last {
            rec.iteration = it;
            rec.residual_norm = rel * bn;
            rec.relative_residual = rel;
            rec.error = None;
            conv.iterations.push(rec);
        }
    }
    if !rel.is_finite() || x.iter().any(|v| !v.is_finite()) {
        return Err(SolverError::Linear(
            "the device solve gave a non-finite solution".into(),
        ));
    }
    conv.final_relative_residual = rel;
    conv.converged = rel <= tolerance;
    if !conv.converged {
        conv.reason = StopReason::MaxIterations;
    }
    Ok((x, conv))
}
