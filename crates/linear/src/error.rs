//! Typed errors of the solvers and operators.
//!
//! Input problems (dimension mismatch, NaN, invalid parameters, a capability the
//! operator lacks) are reported before any work is done; numerical breakdown of a
//! Krylov method that is *not* a happy breakdown is reported with the partial result.

use crate::history::{Method, Solve};

/// A capability an [`crate::Operator`] may lack.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum Unsupported {
    /// `y = Aᵀ x` is not available.
    #[error("the operator cannot apply its transpose")]
    Transpose,
    /// Single rows are not available.
    #[error("the operator cannot return single rows")]
    Row,
    /// Single columns are not available.
    #[error("the operator cannot return single columns")]
    Column,
    /// The diagonal is not available.
    #[error("the operator cannot return its diagonal")]
    Diagonal,
}

/// Errors of the operators and iterative solvers in this crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum LinearError {
    /// A vector or matrix has the wrong size.
    #[error("dimension mismatch for {what}: expected {expected}, got {got}")]
    DimensionMismatch {
        /// Which input has the wrong size.
        what: &'static str,
        /// The size that was required.
        expected: usize,
        /// The size that was supplied.
        got: usize,
    },
    /// An input contains NaN or an infinity.
    #[error("{what} contains a non-finite value at index {index}")]
    NonFiniteInput {
        /// Which input is affected.
        what: &'static str,
        /// The first offending index (row-major for matrices).
        index: usize,
    },
    /// A scalar parameter is out of its admissible range.
    #[error("invalid parameter {what} = {value}: {requirement}")]
    InvalidParameter {
        /// Parameter name.
        what: &'static str,
        /// The rejected value.
        value: f64,
        /// What the parameter must satisfy.
        requirement: &'static str,
    },
    /// A method needs an optional input (e.g. reflectances for the Feda method).
    #[error("{method} needs {what}")]
    MissingInput {
        /// The method that needs it.
        method: Method,
        /// What is missing.
        what: &'static str,
    },
    /// The operator lacks a capability the method needs.
    #[error("{method}: {source}")]
    Unsupported {
        /// The method that needed the capability.
        method: Method,
        /// The missing capability.
        #[source]
        source: Unsupported,
    },
    /// A device backend failed (the payloads name the device and what failed).
    #[error("backend {device}: {message}")]
    Backend {
        /// The device (adapter name).
        device: String,
        /// What failed.
        message: String,
    },
    /// Sparse-matrix construction received an index outside the matrix.
    #[error("entry ({row}, {col}) lies outside a {n}×{n} matrix")]
    IndexOutOfRange {
        /// Row index.
        row: usize,
        /// Column index.
        col: usize,
        /// Matrix dimension.
        n: usize,
    },
    /// The iteration produced NaN or an infinity (divergence, or an operator that
    /// returned non-finite values).
    #[error("{method} produced a non-finite iterate at iteration {iteration}")]
    NonFiniteIterate {
        /// The method.
        method: Method,
        /// The iteration (record index) at which it happened.
        iteration: usize,
    },
    /// A serious (non-happy) breakdown: a division by a quantity that vanished while
    /// the residual did not. The best iterate found so far is returned in `partial`.
    #[error("{method} broke down at iteration {iteration}: {detail}")]
    Breakdown {
        /// The method.
        method: Method,
        /// The iteration at which it happened.
        iteration: usize,
        /// What vanished.
        detail: &'static str,
        /// The iterate and history up to the breakdown.
        partial: Box<Solve>,
    },
}
