//! wavelux-linear: matrix-free operators and iterative solvers with convergence
//! records, following Ziegler ch. 2.3 ("Solution Methods"), §3.2 and §4.2.
//!
//! # Problem forms
//!
//! * General: `A x = b` with an [`Operator`] `A` — [`gmres`], [`cg`], [`cgnr`],
//!   [`bicgstab`], [`jacobi`].
//! * Fixed point / radiosity: `x = b + K x`, i.e. `(I − K) x = b` with the transport
//!   operator `K = R G` (Ziegler §2.3.1; his `F`) — [`picard`], [`gauss_seidel`],
//!   [`sor`], [`southwell`], [`progressive_refinement`], [`overrelaxation`] (Table
//!   2.1). These take `K` itself; Gauss–Seidel-like methods need its columns (and
//!   some its rows). For Krylov methods wrap `K` in [`IdentityMinus`].
//!
//! Operators: [`DenseOperator`] (nalgebra) and [`CsrMatrix`] offer every
//! capability; [`FnOperator`] wraps a closure `y = A x` for matrix-free use (the
//! hierarchical wavelet solver's case, Ziegler §2.3.4), which Picard and the Krylov
//! methods (except CGNR, which needs `Aᵀ`) accept.
//!
//! Unknowns are scalar `f64`: a radiosity solver with RGB unknowns solves each colour
//! channel separately with the same operator (the operator is linear and
//! channel-independent; only `K` with per-channel reflectance differs, in which case
//! one operator per channel is used).
//!
//! Explicit matrices for devices (issue 17 (b)): [`backend`] ([`backend::Matrix`],
//! [`backend::MatVecBackend`], the CPU reference [`backend::CpuMatVec`] and
//! [`backend::BackendOperator`]).
//!
//! # Example
//!
//! ```
//! use nalgebra::DMatrix;
//! use wavelux_linear::{DenseOperator, IdentityMinus, SolverOptions, gmres, picard};
//!
//! // Two facing patches, ρ = 0.5, form factor 0.8 each way: K = R F.
//! let k = DenseOperator::new(DMatrix::from_row_slice(2, 2, &[0.0, 0.4, 0.4, 0.0]))?;
//! let emission = [1.0, 0.0];
//! let opts = SolverOptions::default().with_tolerance(1e-12);
//! let p = picard(&k, &emission, &opts)?; // matrix-free x = b + K x
//! let g = gmres(&IdentityMinus::new(&k), &emission, &opts)?; // (I − K) x = b
//! assert!(p.history.converged && g.history.converged);
//! assert!((g.x[0] - 1.0 / 0.84).abs() < 1e-12);
//! // GMRES needed fewer operator applications than Picard.
//! assert!(g.history.work().applications < p.history.work().applications);
//! # Ok::<(), wavelux_linear::LinearError>(())
//! ```
//!
//! # Records
//!
//! Every solver returns a [`Solve`] whose [`Convergence`] has one
//! [`IterationRecord`] per iteration (residual norm, relative residual, error against
//! an optional reference as in Ziegler §4.2.2, wall time, cumulative [`Work`]).
//! Record 0 is the initial guess. The work counters let methods be compared by cost
//! (applications, transposes, rows, columns) rather than by iteration count.
//!
//! # Errors
//!
//! Bad input (dimension mismatch, NaN/∞, invalid parameters, missing capabilities)
//! is a [`LinearError`] before any work; numerical breakdown that is not a happy
//! breakdown is [`LinearError::Breakdown`] carrying the partial result. Happy
//! breakdowns (GMRES found the exact solution) are successes.

pub mod backend;
pub mod error;
pub mod history;
pub mod krylov;
pub mod operator;
pub mod relaxation;
pub mod stationary;
mod util;

pub use error::{LinearError, Unsupported};
pub use history::{Convergence, IterationRecord, Method, Solve, SolverOptions, StopReason, Work};
pub use krylov::{bicgstab, cg, cgnr, gmres};
pub use operator::{CsrMatrix, DenseOperator, FnOperator, IdentityMinus, Operator};
pub use relaxation::{
    OverrelaxationKind, ProgressiveSolve, gauss_seidel, overrelaxation, progressive_refinement,
    sor, southwell,
};
pub use stationary::{jacobi, picard};
