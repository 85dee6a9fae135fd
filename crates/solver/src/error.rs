//! Typed errors of the solver (input validation, unsupported surfaces, failures of the
//! dependencies it drives).

/// Errors of [`crate::solve`] and the building blocks of this crate.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SolverError {
    /// A configuration value is outside its documented range.
    #[error("invalid solver configuration: `{field}` = {value}: {reason}")]
    InvalidConfig {
        /// Field of [`crate::SolverConfig`].
        field: &'static str,
        /// Offending value, formatted.
        value: String,
        /// What was expected.
        reason: &'static str,
    },
    /// A surface this crate cannot build a support for (e.g. a trimmed patch in
    /// natural coordinates).
    #[error("unsupported surface kind for surface {surface:?}: {kind}")]
    UnsupportedSurface {
        /// Surface name.
        surface: String,
        /// Shape kind and the reason.
        kind: String,
    },
    /// The scene is invalid (material out of range, non-finite data, zero area, ...).
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    /// The basis is not available for this solver (e.g. a non-tree MRA).
    #[error(
        "unsupported basis {0}: tree bases are Haar and M_k (k <= 4); CDV is solved by `solve` (module `cdv`), not as a tree basis"
    )]
    UnsupportedBasis(String),
    /// A dependency (quadrature, MRA, geometry) rejected an internal request.
    #[error("internal {what} error: {message}")]
    Dependency {
        /// Which dependency.
        what: &'static str,
        /// Its message.
        message: String,
    },
    /// The linear solver failed (breakdown, invalid options).
    #[error("linear solver failed: {0}")]
    Linear(String),
    /// An index (surface, patch) out of range in a query.
    #[error("{what} index {index} is out of range (len {len})")]
    OutOfRange {
        /// What was indexed.
        what: &'static str,
        /// The index.
        index: usize,
        /// The length.
        len: usize,
    },
}

impl From<wavelux_support::SupportError> for SolverError {
    fn from(e: wavelux_support::SupportError) -> Self {
        use wavelux_support::SupportError as S;
        match e {
            S::UnsupportedSurface { surface, kind } => Self::UnsupportedSurface { surface, kind },
            S::InvalidScene(m) => Self::InvalidScene(m),
            S::Dependency { what, message } => Self::Dependency { what, message },
            other => Self::InvalidScene(other.to_string()),
        }
    }
}
