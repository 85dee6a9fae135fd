//! wavelux-meshless: the meshless hierarchical basis of Lehtinen et al. (Meshless §2)
//! and precomputed direct-to-indirect relighting on it (Meshless §3).
//!
//! - [`kernel`]: the weight functions (eqs. (8)–(10)) and the 5D distance (eq. (11));
//! - [`basis`]: multilevel Shepard functions, `P` (eq. (7)), `P†` (pull-push),
//!   evaluation (eq. (6)), the neighbour/parent/child DAG;
//! - [`query`]: the [`SurfaceQuery`] interface (§5.1) over a scene's BVH or an
//!   analytic sphere;
//! - [`points`]: importance particles and hierarchical dart throwing (§2.3).

pub mod basis;
pub mod config;
pub mod error;
mod grid;
pub mod kernel;
pub mod points;
pub mod query;
mod sample;

pub use basis::{Basis, BasisPoint};
pub use config::MeshlessConfig;
pub use error::{FileProblem, MeshlessError};
pub use points::{LevelStats, Placement, PlacementStats, place_points};
pub use query::{EmitterSample, SceneSurfaces, SphereInterior, SurfaceHit, SurfaceQuery};

/// Largest number of levels a basis may have.
pub const MAX_LEVELS: usize = 16;
