//! Typed errors of the glossy method.

/// Errors of scene preparation, refinement, solving and evaluation.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GlossyError {
    /// A parameter is outside its documented range.
    #[error("invalid {what}: {reason}")]
    Invalid {
        /// The parameter.
        what: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The scene cannot be solved (names the file and element where known).
    #[error("{file}: {element}: {reason}")]
    Scene {
        /// Scene file (or built-in name).
        file: String,
        /// The element (surface, material, camera).
        element: String,
        /// What is wrong.
        reason: String,
    },
    /// Importance was requested but nothing emits it (no camera, no named patch).
    #[error("importance needs a camera or named importance patches: {0}")]
    NoImportanceSource(String),
    /// A non-finite value appeared where a finite one is required.
    #[error("non-finite {what}: {value}")]
    NonFinite {
        /// What was not finite.
        what: &'static str,
        /// The value.
        value: f64,
    },
    /// A lower crate rejected a request.
    #[error("{what}: {message}")]
    Dependency {
        /// Which crate.
        what: &'static str,
        /// Its message.
        message: String,
    },
}

pub(crate) fn invalid(what: &'static str, reason: impl Into<String>) -> GlossyError {
    GlossyError::Invalid {
        what,
        reason: reason.into(),
    }
}

pub(crate) fn dep<E: std::fmt::Display>(what: &'static str) -> impl Fn(E) -> GlossyError {
    move |e| GlossyError::Dependency {
        what,
        message: e.to_string(),
    }
}
