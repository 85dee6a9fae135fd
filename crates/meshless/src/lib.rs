//! wavelux-meshless: the meshless hierarchical basis of Lehtinen et al. (Meshless §2)
//! and precomputed direct-to-indirect relighting on it (Meshless §3).
//!
//! - [`kernel`]: the weight functions (eqs. (8)–(10)) and the 5D distance (eq. (11));
//! - [`basis`]: multilevel Shepard functions, `P` (eq. (7)), `P†` (pull-push),
//!   evaluation (eq. (6)), the neighbour/parent/child DAG;
//! - [`query`]: the [`SurfaceQuery`] interface (§5.1) over a scene's BVH or an
//!   analytic sphere;
//! - [`points`]: importance particles and hierarchical dart throwing (§2.3);
//! - [`transfer`]: the single-bounce operator `T` by hierarchical refinement (§3.2,
//!   eqs. (16)–(17), Fig. 5); [`bounce`]: `S = Σ S_b` (§3.2);
//! - [`matrix`]: sparse RGB vector-irradiance link matrices;
//! - [`backend`]: the runtime product `i = S·e` behind [`TransferBackend`] (CPU here,
//!   wgpu in `wavelux-gpu`) on one documented f32 layout;
//! - [`direct`]: direct irradiance at the sender points (punctual lights, area
//!   emitters, uniform);
//! - [`relight`]: [`Precomputed`], [`Relighter`], [`Indirect`], flattening (§3.3, §4.1);
//! - [`io`]: save and load of precomputed transfers.

// reason: `!(x > 0.0)` is the idiom that also rejects NaN, which every guard here needs.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod backend;
pub mod basis;
pub mod bounce;
pub mod config;
pub mod direct;
pub mod error;
mod grid;
pub mod io;
pub mod kernel;
pub mod matrix;
pub mod points;
pub mod query;
pub mod relight;
mod sample;
pub mod transfer;

pub use backend::{CpuBackend, PackedTransfer, TransferBackend};
pub use basis::{Basis, BasisPoint};
pub use bounce::BounceStats;
pub use config::{LinkThreshold, MeshlessConfig};
pub use direct::DirectLighting;
pub use error::{FileProblem, MeshlessError};
pub use matrix::{Link, MatrixStats, TransferMatrix, link_norm};
pub use points::{LevelStats, Placement, PlacementStats, place_points};
pub use query::{EmitterSample, SceneSurfaces, SphereInterior, SurfaceHit, SurfaceQuery};
pub use relight::{
    Flat, FlattenOperator, FrameTimes, Indirect, PrecomputeStats, Precomputed, Relighter,
    scene_hash,
};
pub use transfer::{RefineStats, refine};

/// Largest number of levels a basis may have.
pub const MAX_LEVELS: usize = 16;
