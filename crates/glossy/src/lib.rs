//! wavelux-glossy: glossy global illumination with 4D Haar radiance and exitant
//! importance (Christensen, Stollnitz, Salesin, DeRose, "Global Illumination of Glossy
//! Environments Using Wavelets and Importance", ACM TOG 1996 — "Glossy" below).
//!
//! Radiance `L(x, ω)` on every lit side ("patch") is a function on
//! `[0,1]² × H²`, mapped to `[0,1]⁴` by the patch's equal-area support (space) and a
//! hemisphere ↔ square map (direction, §3.3), and expanded in non-standard 4D Haar
//! wavelets (§3.4). Transport between basis functions uses the standard operator
//! decomposition (§3.5): links carry coefficients from one sending function to the 15
//! wavelets of a receiving node. Exitant importance emitted by an eye patch obeys the
//! same equation and is carried by the same links (§4.2); an oracle weighing radiance,
//! kernel variation and importance picks which links to add (§5.3). A final gather
//! renders the solution (§5.5).
//!
//! Modules, bottom-up:
//! - [`ward`]: the Ward BRDF (three normalisations), sampling with the exact pdf,
//!   albedos, shading frames, cosine-power emitters (§6.2–§6.3);
//! - [`directions`]: the hemisphere ↔ square maps and exact cell integrals;
//! - [`basis`]: 4D Haar nodes and the two-scale step;
//! - [`tree`]: per-patch trees and the coefficient arrays (six bands);
//! - [`patch`]: the prepared scene (patches, BRDFs, textures, eye, BVH);
//! - [`emission`]: up-front decomposition of emitters and the eye's importance;
//! - [`transport`]: transport coefficients by eq. (5);
//! - [`link`]: links and their indices;
//! - [`nonstandard`]: the non-standard decomposition (scaling links, push/pull, §3.5);
//! - [`solve`]: Gauss–Seidel, Picard and GMRES on the links;
//! - [`refine`]: candidates, oracle values, importance arriving at supports, rebuild;
//! - [`solution`]: the solver loop, evaluation, exitance, final gather, images;
//! - [`config`]: every knob.
//!
//! **Invariants:** never depends on another method crate (only on `wavelux-support`
//! and the layers below); results are bitwise identical for any thread count
//! (per-link and per-node seeded streams, fixed reduction orders).

pub mod basis;
pub mod config;
pub mod directions;
pub mod emission;
pub mod error;
pub mod link;
pub mod nonstandard;
pub mod patch;
pub mod refine;
pub mod solution;
pub mod solve;
pub mod transport;
pub mod tree;
pub mod ward;

pub use config::{GatherMode, GlossyConfig};

/// `x > 0` (false for NaN): negations of it read as "not positive", NaN included.
#[inline]
pub(crate) fn positive(x: f64) -> bool {
    x > 0.0
}
pub use directions::DirectionKind;
pub use error::GlossyError;
pub use nonstandard::Decomposition;
pub use patch::{GlossyScene, ImportanceSource, Patch};
pub use solution::{GlossySolution, GlossyStats, RoundStats};
pub use solve::LinearSolver;
pub use transport::TransportOptions;
pub use ward::{Brdf, Frame, WardLobe, WardVariant};
