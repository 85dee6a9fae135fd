//! Typed errors of the meshless method: bad configuration, unusable viewpoints, empty
//! levels, exhausted budgets, bad lights and direct-lighting vectors, unreadable
//! transfer files. Nothing in the crate panics on bad input.

/// What is wrong with a transfer file (see `io`).
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum FileProblem {
    /// The file does not start with the magic bytes.
    Magic,
    /// The file was written by another format version.
    Version {
        /// Version in the file.
        found: u32,
        /// Version this build reads.
        expected: u32,
    },
    /// The file belongs to another scene (or another configuration of it).
    SceneHash {
        /// Hash in the file.
        found: u64,
        /// Hash of the scene given.
        expected: u64,
    },
    /// The file ends early or a section's length is inconsistent.
    Truncated,
    /// A value in the file is out of range (index, non-finite number).
    Corrupt(String),
}

impl std::fmt::Display for FileProblem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Magic => write!(f, "not a wavelux meshless transfer file (bad magic)"),
            Self::Version { found, expected } => {
                write!(f, "format version {found}, this build reads {expected}")
            }
            Self::SceneHash { found, expected } => write!(
                f,
                "precomputed for another scene (hash {found:016x}, scene has {expected:016x})"
            ),
            Self::Truncated => write!(f, "truncated"),
            Self::Corrupt(what) => write!(f, "corrupt: {what}"),
        }
    }
}

/// Errors of the meshless basis, the precomputation and relighting.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MeshlessError {
    /// A configuration value is out of its documented range.
    #[error("invalid meshless configuration: {what}: {reason}")]
    Config {
        /// The option.
        what: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The viewpoint of point placement is non-finite or sees no surface.
    #[error("viewpoint {viewpoint:?}: {reason}")]
    Viewpoint {
        /// The viewpoint.
        viewpoint: [f64; 3],
        /// What is wrong.
        reason: String,
    },
    /// A level received no points.
    #[error(
        "level {level} is empty (Poisson-disk spacing R = {spacing}): no candidate point could be placed; use fewer levels or a smaller R"
    )]
    EmptyLevel {
        /// The level.
        level: usize,
        /// Its Poisson-disk spacing `R` (scene units), or the support radius for a
        /// basis built from given points.
        spacing: f64,
    },
    /// A point or link budget was exhausted.
    #[error("{what} budget of {limit} exhausted (raise the budget, R_coarse or ε)")]
    Budget {
        /// `points` or `links`.
        what: &'static str,
        /// The limit.
        limit: usize,
    },
    /// A light is invalid.
    #[error("light {index} ({name:?}): {reason}")]
    Light {
        /// Index in the list given.
        index: usize,
        /// Its name.
        name: String,
        /// What is wrong.
        reason: String,
    },
    /// A vector has the wrong length.
    #[error("{what}: length {len}, expected {expected}")]
    Length {
        /// Which vector.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The expected length.
        expected: usize,
    },
    /// A value of an input vector is not finite or negative where it must not be.
    #[error("{what}: element {index} is {value} (must be finite{sign})")]
    BadValue {
        /// Which vector.
        what: &'static str,
        /// The element (point index).
        index: usize,
        /// The value.
        value: f64,
        /// `" and >= 0"` where negatives are refused.
        sign: &'static str,
    },
    /// The scene cannot be used (no geometry, invalid materials, an emitter the
    /// direct lighting cannot sample).
    #[error("scene {scene:?}: {reason}")]
    Scene {
        /// The scene's name.
        scene: String,
        /// What is wrong.
        reason: String,
    },
    /// A transfer file cannot be used.
    #[error("{path}: {problem}")]
    File {
        /// The file.
        path: String,
        /// What is wrong.
        problem: FileProblem,
    },
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// The operating-system message.
        message: String,
    },
}

impl MeshlessError {
    pub(crate) fn config(what: &'static str, reason: impl Into<String>) -> Self {
        Self::Config {
            what,
            reason: reason.into(),
        }
    }
}
