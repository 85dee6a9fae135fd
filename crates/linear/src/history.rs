//! Solver options, convergence records and results shared by every method.
//!
//! Every solver returns a [`Solve`]: the iterate and a [`Convergence`] history with one
//! [`IterationRecord`] per iteration (record 0 is the initial guess). Errors against a
//! supplied reference follow Ziegler §4.2.2: the relative Euclidean error
//! `‖x − x̂‖₂ / ‖x̂‖₂` (absolute `‖x‖₂` when the reference is zero).

use std::fmt;
use std::time::Duration;

use serde::{Deserialize, Serialize};

use crate::relaxation::OverrelaxationKind;

/// The iterative method that produced a result.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum Method {
    /// Picard iteration `x ← b + K x` (Neumann series, Ziegler §2.3.2 eq. (2.16)).
    Picard,
    /// Jacobi iteration `x ← x + D⁻¹(b − A x)` on a general operator.
    Jacobi,
    /// Gauss–Seidel (cyclic relaxation, Ziegler Alg. 2.3.1).
    GaussSeidel,
    /// Successive overrelaxation, `Δ = ω r_i / m_ii` (Ziegler Alg. 2.3.3).
    Sor,
    /// Southwell relaxation: largest weighted residual first (Ziegler §2.3.2).
    Southwell,
    /// Progressive refinement (Ziegler Alg. 2.3.2, Cohen et al. 1988).
    ProgressiveRefinement,
    /// One of the overrelaxation choices of Ziegler Table 2.1.
    Overrelaxation(OverrelaxationKind),
    /// Restarted GMRES(m) (Saad 1996 §6.5, used by Ziegler §3.2).
    Gmres,
    /// Conjugate gradients for symmetric positive definite operators.
    Cg,
    /// CG on the normal equations `AᵀA x = Aᵀ b` (CGNR, Saad §8.3).
    Cgnr,
    /// Stabilised bi-conjugate gradients (van der Vorst 1992).
    BiCgStab,
}

impl fmt::Display for Method {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Method::Picard => write!(f, "Picard"),
            Method::Jacobi => write!(f, "Jacobi"),
            Method::GaussSeidel => write!(f, "Gauss-Seidel"),
            Method::Sor => write!(f, "SOR"),
            Method::Southwell => write!(f, "Southwell"),
            Method::ProgressiveRefinement => write!(f, "progressive refinement"),
            Method::Overrelaxation(k) => write!(f, "{k:?} overrelaxation"),
            Method::Gmres => write!(f, "GMRES"),
            Method::Cg => write!(f, "CG"),
            Method::Cgnr => write!(f, "CGNR"),
            Method::BiCgStab => write!(f, "BiCGSTAB"),
        }
    }
}

/// Cumulative work spent by a solver, so that methods can be compared honestly
/// (Ziegler §4.2.3 compares iterations; one GMRES or Picard iteration costs one
/// operator application, one CGNR or BiCGSTAB iteration costs two).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Work {
    /// Applications `y = A x` (or `y = K x`) of the full operator.
    pub applications: u64,
    /// Applications of the transpose.
    pub transpose_applications: u64,
    /// Single rows fetched from the operator.
    pub rows: u64,
    /// Single columns fetched from the operator.
    pub columns: u64,
}

impl Work {
    /// Total cost in units of full operator applications for a system of dimension
    /// `n`: applications + transpose applications + (rows + columns) / n. This treats
    /// one row or column as `1/n` of an application, which is exact for dense
    /// matrices and the usual accounting for relaxation methods ("one sweep").
    pub fn application_equivalents(&self, n: usize) -> f64 {
        let n = n.max(1) as f64;
        self.applications as f64
            + self.transpose_applications as f64
            + (self.rows + self.columns) as f64 / n
    }
}

/// The state after one iteration of a solver.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct IterationRecord {
    /// Iteration index; 0 is the initial guess. For relaxation methods one iteration
    /// is [`SolverOptions::updates_per_record`] single-variable updates (default `n`,
    /// one sweep).
    pub iteration: usize,
    /// Euclidean norm of the residual the method tracks. Krylov methods: `‖b − A x‖₂`
    /// (GMRES: the least-squares estimate inside a cycle, which equals the true
    /// residual in exact arithmetic). Progressive refinement: the unshot residual
    /// `r` of Ziegler Alg. 2.3.2, i.e. the residual of `x̂ − r`, not of `x̂`.
    pub residual_norm: f64,
    /// `residual_norm / ‖b‖₂` (equal to `residual_norm` when `b = 0`).
    pub relative_residual: f64,
    /// Relative error against [`SolverOptions::reference`], when one was given.
    pub error: Option<f64>,
    /// Wall time since the solver started.
    pub elapsed: Duration,
    /// Cumulative work up to and including this iteration.
    pub work: Work,
}

/// Why a solver stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[non_exhaustive]
pub enum StopReason {
    /// The relative residual reached the tolerance.
    Converged,
    /// A Krylov method found an invariant subspace: the iterate is exact up to
    /// rounding (GMRES `h_{j+1,j} = 0`, BiCGSTAB `s = 0`).
    HappyBreakdown,
    /// The iteration limit was reached first.
    MaxIterations,
    /// A serious breakdown; only used for the partial result carried by
    /// [`crate::LinearError::Breakdown`].
    Breakdown,
}

/// The convergence history of one solve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Convergence {
    /// One record per iteration, starting with the initial guess.
    pub iterations: Vec<IterationRecord>,
    /// Whether the tolerance was met (or a happy breakdown occurred).
    pub converged: bool,
    /// Why the solver stopped.
    pub reason: StopReason,
    /// `‖b − A x‖₂ / ‖b‖₂` recomputed from scratch for the returned `x` with one
    /// extra operator application that is *not* counted in [`Work`]. Use this to
    /// check for drift of recursively updated residuals.
    pub final_relative_residual: f64,
    /// Table 2.1 overrelaxation only: updates where the safeguard replaced the
    /// method's step by the plain Southwell step (see [`crate::relaxation`]);
    /// 0 for every other method.
    pub safeguarded_updates: u64,
}

impl Convergence {
    /// The last record (there is always at least the initial one).
    pub fn last(&self) -> &IterationRecord {
        self.iterations
            .last()
            .expect("a convergence history always holds the initial record")
    }

    /// Total work of the solve.
    pub fn work(&self) -> Work {
        self.last().work
    }

    /// The relative residual of every record, for plotting convergence curves.
    pub fn relative_residuals(&self) -> Vec<f64> {
        self.iterations
            .iter()
            .map(|r| r.relative_residual)
            .collect()
    }

    /// The error of every record (`None` without a reference), for plotting.
    pub fn errors(&self) -> Vec<Option<f64>> {
        self.iterations.iter().map(|r| r.error).collect()
    }
}

/// Result of a solve.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Solve {
    /// The method that produced it.
    pub method: Method,
    /// The approximate solution (length `n`).
    pub x: Vec<f64>,
    /// The convergence history.
    pub history: Convergence,
}

/// Options shared by all solvers. Build with [`SolverOptions::default`] and the
/// `with_*` methods. Every solver validates the options (lengths, finiteness, ranges
/// stated per field) before doing any work.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub struct SolverOptions {
    /// Maximum number of iterations (records after the initial one). Default 1000.
    pub max_iterations: usize,
    /// Stop when `‖r‖₂ / ‖b‖₂ ≤ tolerance`. Default `1e-10`; must be finite and ≥ 0.
    pub tolerance: f64,
    /// Initial guess; `None` means `x⁽⁰⁾ = 0` (residual `b`, no application needed).
    pub initial_guess: Option<Vec<f64>>,
    /// Reference solution for the error column of the records.
    pub reference: Option<Vec<f64>>,
    /// GMRES restart length `m` (Krylov dimension per cycle). Default 30; ≥ 1.
    pub restart: usize,
    /// GMRES: second modified Gram–Schmidt pass against loss of orthogonality.
    /// Default `true`.
    pub reorthogonalize: bool,
    /// SOR relaxation factor `ω ∈ (0, 2)`. Default 1.
    pub omega: f64,
    /// Relaxation methods: single-variable updates per record. `None` = `n` (one
    /// sweep per record).
    pub updates_per_record: Option<usize>,
    /// Area weights `A_i > 0` (Ziegler's `D_A`) for Southwell / progressive
    /// refinement selection, Table 2.1 methods and the ambient term. `None` = all 1.
    pub areas: Option<Vec<f64>>,
    /// Reflectances `ρ_i ∈ [0, 1)` (Ziegler's `R`), needed by the Feda and Xu
    /// methods and by the ambient term of progressive refinement.
    pub reflectance: Option<Vec<f64>>,
}

impl Default for SolverOptions {
    fn default() -> Self {
        Self {
            max_iterations: 1000,
            tolerance: 1e-10,
            initial_guess: None,
            reference: None,
            restart: 30,
            reorthogonalize: true,
            omega: 1.0,
            updates_per_record: None,
            areas: None,
            reflectance: None,
        }
    }
}

impl SolverOptions {
    /// Sets [`Self::max_iterations`].
    pub fn with_max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }
    /// Sets [`Self::tolerance`].
    pub fn with_tolerance(mut self, tol: f64) -> Self {
        self.tolerance = tol;
        self
    }
    /// Sets [`Self::initial_guess`].
    pub fn with_initial_guess(mut self, x0: Vec<f64>) -> Self {
        self.initial_guess = Some(x0);
        self
    }
    /// Sets [`Self::reference`].
    pub fn with_reference(mut self, x: Vec<f64>) -> Self {
        self.reference = Some(x);
        self
    }
    /// Sets [`Self::restart`].
    pub fn with_restart(mut self, m: usize) -> Self {
        self.restart = m;
        self
    }
    /// Sets [`Self::reorthogonalize`].
    pub fn with_reorthogonalize(mut self, on: bool) -> Self {
        self.reorthogonalize = on;
        self
    }
    /// Sets [`Self::omega`].
    pub fn with_omega(mut self, omega: f64) -> Self {
        self.omega = omega;
        self
    }
    /// Sets [`Self::updates_per_record`].
    pub fn with_updates_per_record(mut self, k: usize) -> Self {
        self.updates_per_record = Some(k);
        self
    }
    /// Sets [`Self::areas`].
    pub fn with_areas(mut self, areas: Vec<f64>) -> Self {
        self.areas = Some(areas);
        self
    }
    /// Sets [`Self::reflectance`].
    pub fn with_reflectance(mut self, rho: Vec<f64>) -> Self {
        self.reflectance = Some(rho);
        self
    }
}
