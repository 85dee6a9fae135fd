//! Small dense vector kernels, input validation and the convergence recorder shared
//! by all solvers (internal).

use std::time::Instant;

use crate::error::LinearError;
use crate::history::{
    Convergence, IterationRecord, Method, Solve, SolverOptions, StopReason, Work,
};
use crate::operator::Operator;

pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

pub(crate) fn norm(a: &[f64]) -> f64 {
    dot(a, a).sqrt()
}

/// `y += alpha * x`.
pub(crate) fn axpy(alpha: f64, x: &[f64], y: &mut [f64]) {
    for (yi, xi) in y.iter_mut().zip(x) {
        *yi += alpha * xi;
    }
}

pub(crate) fn all_finite(a: &[f64]) -> bool {
    a.iter().all(|v| v.is_finite())
}

/// Checks length and finiteness of an input vector.
pub(crate) fn check_vector(what: &'static str, v: &[f64], n: usize) -> Result<(), LinearError> {
    if v.len() != n {
        return Err(LinearError::DimensionMismatch {
            what,
            expected: n,
            got: v.len(),
        });
    }
    if let Some(index) = v.iter().position(|x| !x.is_finite()) {
        return Err(LinearError::NonFiniteInput { what, index });
    }
    Ok(())
}

/// Validates the right-hand side and every option against dimension `n`.
pub(crate) fn check_inputs(b: &[f64], n: usize, opts: &SolverOptions) -> Result<(), LinearError> {
    check_vector("right-hand side", b, n)?;
    if !(opts.tolerance.is_finite() && opts.tolerance >= 0.0) {
        return Err(LinearError::InvalidParameter {
            what: "tolerance",
            value: opts.tolerance,
            requirement: "must be finite and non-negative",
        });
    }
    if let Some(x0) = &opts.initial_guess {
        check_vector("initial guess", x0, n)?;
    }
    if let Some(r) = &opts.reference {
        check_vector("reference solution", r, n)?;
    }
    if let Some(a) = &opts.areas {
        check_vector("area weights", a, n)?;
        if let Some(&bad) = a.iter().find(|&&v| v <= 0.0) {
            return Err(LinearError::InvalidParameter {
                what: "area weight",
                value: bad,
                requirement: "must be positive",
            });
        }
    }
    if let Some(rho) = &opts.reflectance {
        check_vector("reflectance", rho, n)?;
        if let Some(&bad) = rho.iter().find(|&&v| !(0.0..1.0).contains(&v)) {
            return Err(LinearError::InvalidParameter {
                what: "reflectance",
                value: bad,
                requirement: "must lie in [0, 1)",
            });
        }
    }
    if opts.restart == 0 {
        return Err(LinearError::InvalidParameter {
            what: "restart",
            value: 0.0,
            requirement: "must be at least 1",
        });
    }
    if !(opts.omega > 0.0 && opts.omega < 2.0) {
        return Err(LinearError::InvalidParameter {
            what: "omega",
            value: opts.omega,
            requirement: "must lie in (0, 2)",
        });
    }
    if opts.updates_per_record == Some(0) {
        return Err(LinearError::InvalidParameter {
            what: "updates_per_record",
            value: 0.0,
            requirement: "must be at least 1",
        });
    }
    Ok(())
}

/// Collects [`IterationRecord`]s, checks convergence and finiteness.
pub(crate) struct Recorder<'a> {
    method: Method,
    start: Instant,
    b_norm: f64,
    tolerance: f64,
    reference: Option<&'a [f64]>,
    reference_norm: f64,
    records: Vec<IterationRecord>,
    /// Cumulative work; solvers increment it directly.
    pub(crate) work: Work,
}

impl<'a> Recorder<'a> {
    pub(crate) fn new(method: Method, b: &[f64], opts: &'a SolverOptions) -> Self {
        let reference = opts.reference.as_deref();
        Self {
            method,
            start: Instant::now(),
            b_norm: norm(b),
            tolerance: opts.tolerance,
            reference,
            reference_norm: reference.map_or(0.0, norm),
            records: Vec::new(),
            work: Work::default(),
        }
    }

    pub(crate) fn method(&self) -> Method {
        self.method
    }

    /// Whether records carry an error (callers may skip forming `x` otherwise).
    pub(crate) fn wants_error(&self) -> bool {
        self.reference.is_some()
    }

    /// Relative residual for a residual norm.
    pub(crate) fn relative(&self, residual_norm: f64) -> f64 {
        if self.b_norm > 0.0 {
            residual_norm / self.b_norm
        } else {
            residual_norm
        }
    }

    pub(crate) fn is_converged(&self, residual_norm: f64) -> bool {
        self.relative(residual_norm) <= self.tolerance
    }

    /// Index the next record will get.
    pub(crate) fn next_iteration(&self) -> usize {
        self.records.len()
    }

    /// Relative error of `x` against the reference, if one was given.
    pub(crate) fn error_of(&self, x: &[f64]) -> Option<f64> {
        self.reference.map(|r| {
            let d: f64 = r.iter().zip(x).map(|(a, b)| (a - b) * (a - b)).sum();
            if self.reference_norm > 0.0 {
                d.sqrt() / self.reference_norm
            } else {
                d.sqrt()
            }
        })
    }

    /// Appends a record; `x` is used for the error column when a reference exists.
    /// Returns whether the tolerance is met.
    pub(crate) fn record(
        &mut self,
        residual_norm: f64,
        x: Option<&[f64]>,
    ) -> Result<bool, LinearError> {
        let iteration = self.records.len();
        if !residual_norm.is_finite() || x.is_some_and(|x| !all_finite(x)) {
            return Err(LinearError::NonFiniteIterate {
                method: self.method,
                iteration,
            });
        }
        let error = x.and_then(|x| self.error_of(x));
        self.records.push(IterationRecord {
            iteration,
            residual_norm,
            relative_residual: self.relative(residual_norm),
            error,
            elapsed: self.start.elapsed(),
            work: self.work,
        });
        Ok(self.is_converged(residual_norm))
    }

    /// Builds the result; `final_residual` is the recomputed `‖b − A x‖₂`.
    pub(crate) fn finish(self, x: Vec<f64>, reason: StopReason, final_residual: f64) -> Solve {
        let converged = matches!(reason, StopReason::Converged | StopReason::HappyBreakdown);
        let final_relative_residual = self.relative(final_residual);
        Solve {
            method: self.method,
            x,
            history: Convergence {
                iterations: self.records,
                converged,
                reason,
                final_relative_residual,
                safeguarded_updates: 0,
            },
        }
    }
}

/// `‖b − A x‖₂` computed from scratch (uncounted application).
pub(crate) fn residual_norm_of<A: Operator + ?Sized>(a: &A, b: &[f64], x: &[f64]) -> f64 {
    let mut ax = vec![0.0; b.len()];
    a.apply(x, &mut ax);
    b.iter()
        .zip(&ax)
        .map(|(bi, yi)| (bi - yi) * (bi - yi))
        .sum::<f64>()
        .sqrt()
}

/// `‖b − (I − K) x‖₂` computed from scratch (uncounted application).
pub(crate) fn fixed_point_residual_norm<K: Operator + ?Sized>(k: &K, b: &[f64], x: &[f64]) -> f64 {
    let mut kx = vec![0.0; b.len()];
    k.apply(x, &mut kx);
    b.iter()
        .zip(&kx)
        .zip(x)
        .map(|((bi, ki), xi)| {
            let r = bi + ki - xi;
            r * r
        })
        .sum::<f64>()
        .sqrt()
}
