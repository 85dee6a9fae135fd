//! wavelux-geometry: exact primitives, trims, ray intersection, BVH visibility and
//! analytic form factors.
//!
//! - [`primitive`]: triangles, parallelograms, planar complex polygons (segment/arc
//!   boundaries, holes), trimmed patches on every `wavelux-param` surface, bicubic Bézier patches; [`Aabb`],
//!   [`Ray`], [`Hit`].
//! - [`trim`]: trim loops and the slab decomposition of VirtualMesh §4.2 / Fig. 6.
//! - [`accel`]: the obvhs BVH over all primitives: closest hit, occlusion, batches.
//! - [`backend`]: the occlusion backend contract ([`backend::Occluder`],
//!   [`backend::OcclusionBackend`]) with the CPU reference, and [`Accel::export`].
//! - [`formfactor`]: analytic form factors (Lambert point-to-polygon, contour integral
//!   polygon-to-polygon, catalog configurations).
//! - [`bezier`]: bicubic Bézier evaluation and subdivision.
//! - [`mod@tessellate`]: tessellated baselines (spade CDT for polygons and trims, uniform or
//!   curvature-adaptive grids for curved patches) as indexed triangle meshes.
//! - [`intersect`]: exact ray intersection for every primitive; [`poly`]: robust polynomial roots.
//!
//! ```
//! use glam::DVec3;
//! use wavelux_geometry::{Accel, Parallelogram, Primitive};
//!
//! // A unit square blocker between two points.
//! let wall = Parallelogram::new(DVec3::new(-0.5, -0.5, 1.0), DVec3::X, DVec3::Y).unwrap();
//! let acc = Accel::build(vec![Primitive::from(wall)]).unwrap();
//! assert!(acc.occluded(DVec3::ZERO, DVec3::new(0.0, 0.0, 2.0), [None, None]));
//! assert!(!acc.occluded(DVec3::ZERO, DVec3::new(2.0, 0.0, 0.0), [None, None]));
//! ```

pub mod accel;
pub mod backend;
pub mod bezier;
pub mod formfactor;
pub mod intersect;
pub mod poly;
pub mod primitive;
pub mod tessellate;
pub mod trim;

pub use accel::{Accel, OcclusionQuery};
pub use primitive::{
    Aabb, BezierPatch, ComplexPolygon, Hit, Parallelogram, PlaneFrame, PrimId, Primitive, Ray,
    Triangle, TrimmedPatch,
};
pub use tessellate::{
    Grid, PrimitiveMesh, TessellationError, TessellationOptions, TriangleMesh, tessellate,
    tessellate_all,
};
pub use trim::{Edge2, RegionFault, TrimLoop, TrimRegion};

/// Errors of geometric construction and queries.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum GeometryError {
    /// An input contained NaN or an infinity (the payload names the input).
    #[error("non-finite input: {0}")]
    NonFinite(&'static str),
    /// The input is geometrically degenerate (the payload says how).
    #[error("degenerate geometry: {0}")]
    Degenerate(&'static str),
    /// A device backend failed (the payloads name the device and what failed).
    #[error("backend {device}: {message}")]
    Backend {
        /// The device (adapter name, or "cpu").
        device: String,
        /// What failed.
        message: String,
    },
    /// Trim loops that do not bound a proper region (the payload names the loop or pair
    /// at fault and how).
    #[error("improper trim region: {0}")]
    Region(trim::RegionFault),
    /// An index was out of range.
    #[error("index {index} out of range (len {len})")]
    OutOfRange {
        /// Offending index.
        index: usize,
        /// Collection length.
        len: usize,
    },
}
