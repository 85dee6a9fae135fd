//! The crate's error type: every bad input names the medium and, where there is one,
//! the voxel (GlobalCube needs none of this; it is the project's bad-input rule).

/// Errors of the volume method. Each names the medium (and voxel `[x, y, z]` where one
/// is at fault) so that a user can find the bad value in the file.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum VolumeError {
    /// A grid value is NaN or infinite.
    #[error("medium {medium:?}: {what} at voxel {voxel:?} is not finite ({value})")]
    NonFinite {
        /// The medium.
        medium: String,
        /// Which grid (`opacity`, `source`, `albedo`).
        what: String,
        /// Voxel `[x, y, z]`.
        voxel: [usize; 3],
        /// The value.
        value: f64,
    },
    /// A grid value is outside its documented range.
    #[error("medium {medium:?}: {what} at voxel {voxel:?} is {value}, outside {range}")]
    OutOfRange {
        /// The medium.
        medium: String,
        /// Which grid.
        what: String,
        /// Voxel `[x, y, z]`.
        voxel: [usize; 3],
        /// The value.
        value: f64,
        /// The allowed range, in words.
        range: String,
    },
    /// The grids of one medium disagree in shape, or a shape is empty.
    #[error("medium {medium:?}: {what}")]
    Shape {
        /// The medium.
        medium: String,
        /// What is wrong.
        what: String,
    },
    /// Voxels must be cubes (the Global Cube projects onto the six faces of a cube).
    #[error(
        "medium {medium:?}: voxels are {size:?} (scene units), not cubes (relative tolerance 1e-9)"
    )]
    NonCubicVoxels {
        /// The medium.
        medium: String,
        /// Voxel edge lengths `[x, y, z]`.
        size: [f64; 3],
    },
    /// More hierarchy levels than the padded grid has.
    #[error(
        "medium {medium:?}: {levels} levels requested but the padded grid of side {side} has at most {max} (log2 of the side)"
    )]
    Levels {
        /// The medium.
        medium: String,
        /// Requested levels `L` (`M = m0 + L`).
        levels: usize,
        /// Side of the padded cubic grid.
        side: usize,
        /// Largest valid `L`.
        max: usize,
    },
    /// A configuration value is out of range (framebuffer, thresholds, tolerance ...).
    #[error("invalid {what}: {reason}")]
    Config {
        /// The option.
        what: String,
        /// Why it is invalid.
        reason: String,
    },
    /// A backend (projector) failed or was handed inconsistent data.
    #[error("projector {backend}: {reason}")]
    Backend {
        /// The backend's name.
        backend: String,
        /// What went wrong.
        reason: String,
    },
    /// The linear solver failed (GMRES breakdown, non-finite iterate ...).
    #[error("solver: {0}")]
    Solver(String),
}

pub(crate) fn config(what: &str, reason: impl Into<String>) -> VolumeError {
    VolumeError::Config {
        what: what.into(),
        reason: reason.into(),
    }
}
