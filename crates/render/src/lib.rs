//! wavelux-render: cameras, images, final gather, exports and a Monte Carlo reference
//! for wavelux radiosity solutions.
//!
//! - [`camera`]: pinhole/orthographic views from glTF cameras or an explicit look-at,
//!   primary rays (glTF 2.0 §3.10 conventions);
//! - [`field`]: the [`RadiosityField`] trait (anything that gives the exitant radiosity
//!   at a ray hit) and [`SolutionField`], its implementation for a
//!   `wavelux_solver::Solution` (the hit's `(patch, s, t)` by inverting the patch's
//!   equal-area support map);
//! - [`meshless_field`]: [`MeshlessField`], a `wavelux-meshless` relighting result
//!   (direct lighting composited with the indirect expansion, Meshless §3.3);
//! - [`radiance`]: the [`RadianceField`] trait (radiance `L(x, ω)` at a hit: a
//!   glossy solution, the glossy path tracer, or any radiosity field as `B/π`) and
//!   [`render_radiance`], its images;
//! - [`render`](mod@render): images of a field, optionally with one-bounce final gather
//!   (Glossy §5.5) or exact direct light plus the field's indirect part;
//! - [`direct`]: exact direct light (unoccluded form factors times kernel-weighted
//!   visible fractions of stratified shadow rays);
//! - [`image`]: linear RGB images, EXR (exr crate) and tone-mapped sRGB PNG (png crate)
//!   I/O, error metrics and false-colour error maps; every file is written through a
//!   temporary file and an atomic rename;
//! - [`reference`]: a Monte Carlo path tracer for diffuse scenes (the ground truth for
//!   scenes without closed forms), [`reference::glossy`], its glossy twin (Ward BRDFs,
//!   cosine-power emitters, `radiance_at(point, ω)`), and [`reference::volume`], a particle tracer for
//!   voxel media (the ground truth of the volume method);
//! - [`texels`]: lightmap-like texel grids over every lit side at a fixed density,
//!   any field evaluated on them, and the area-weighted relative L1 error of the
//!   function against a path-traced texel reference with its noise floor;
//! - [`volume_image`]: the emission–absorption image and slices of a solved medium
//!   (`wavelux_volume`, GlobalCube §3.1);
//! - [`export`]: glTF export with baked per-vertex radiosity and per-patch lightmaps.
//!
//! # Units
//! Radiosity `B` and emission `E` are exitances in W/m² per RGB channel (the
//! convention of `wavelux-scene`); image pixels hold radiance `L = B/π` in
//! W/(m²·sr) (Lambertian surfaces), so an EXR of a surface of radiosity `B` reads
//! `B/π`.

mod area;
pub mod camera;
pub mod direct;
pub mod export;
pub mod field;
pub mod image;
pub mod meshless_field;
pub mod radiance;
pub mod reference;
pub mod render;
mod sampling;
pub mod texels;
pub mod volume_image;

pub use camera::{View, auto_camera, scene_up};
pub use direct::DirectLight;
pub use field::{EmitterSample, RadiosityField, SolutionField, SurfacePoint, side_average};
pub use image::{ErrorMetrics, Image, ToneMap, write_atomic};
pub use meshless_field::{Component, IndirectSource, MeshlessField};
pub use radiance::{Diffuse, GlossyField, RadianceField, RadianceOptions, render_radiance};
pub use reference::glossy::{GlossyTracer, TracedRadiance};
pub use reference::{PathTracer, ReferenceOptions, SurfaceEstimate};
pub use render::{RenderOptions, RenderStats, render};
pub use texels::{Texel, TexelGrid, TexelMetrics, TexelValues};
pub use volume_image::{render_volume, volume_slice};

/// Errors of the renderer, exporters and the reference.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum RenderError {
    /// An argument is out of its documented range.
    #[error("invalid {what}: {reason}")]
    Invalid {
        /// The argument.
        what: &'static str,
        /// Why it is invalid.
        reason: String,
    },
    /// The scene cannot be handled (e.g. no geometry, an unsupported primitive).
    #[error("scene: {0}")]
    Scene(String),
    /// Reading or writing a file failed.
    #[error("{path}: {message}")]
    Io {
        /// The file.
        path: String,
        /// What went wrong.
        message: String,
    },
    /// Two images cannot be compared (different sizes).
    #[error("image size mismatch: {0}x{1} vs {2}x{3}")]
    SizeMismatch(usize, usize, usize, usize),
}

pub(crate) fn invalid(what: &'static str, reason: impl Into<String>) -> RenderError {
    RenderError::Invalid {
        what,
        reason: reason.into(),
    }
}
