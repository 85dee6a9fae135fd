//! Typed errors of support construction.

/// Errors of [`crate::build_supports`], [`crate::Support::mapped`] and
/// [`crate::Mask::new`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SupportError {
    /// A surface no support can be built for (e.g. a trimmed patch in natural
    /// coordinates whose trim has a point without a preimage).
    #[error("unsupported surface kind for surface {surface:?}: {kind}")]
    UnsupportedSurface {
        /// Surface name.
        surface: String,
        /// Shape kind and the reason.
        kind: String,
    },
    /// The scene is invalid (non-finite data, zero area, degenerate trims, ...).
    #[error("invalid scene: {0}")]
    InvalidScene(String),
    /// A dependency (quadrature) rejected an internal request.
    #[error("internal {what} error: {message}")]
    Dependency {
        /// Which dependency.
        what: &'static str,
        /// Its message.
        message: String,
    },
}
