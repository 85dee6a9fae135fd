//! wavelux-param: parametrized surfaces, equal-area maps onto the unit square, direction
//! maps and minimal enclosing parallelograms.
//!
//! This crate implements the geometric half of the virtual mesh (VirtualMesh §3):
//!
//! * [`Parametrization`] — a map from [0, 1]² onto a surface patch with its inverse,
//!   Jacobian (area element), area and bounds; every surface offers an equal-area
//!   (constant-Jacobian, "energy-preserving", §3.1 eq. (1)) map and its natural map
//!   side by side ([`ParamKind`]).
//! * Closed-form equal-area maps: [`Parallelogram`] (the affine Λ of §3.3),
//!   [`Cylinder`], [`Cone`] `(θ, φ²)`, [`Sphere`] `(θ, sin φ)` (Appendix A.1).
//!
//! * [`Spheroid`] (prolate and oblate, Appendix A.1, stable as e → 0 and e → 1) and
//!   ring [`Torus`] patches with general radii (§3.1.3; numerical inverse by
//!   safeguarded Newton).
//! * Numerical equal-area maps via eq. (2) (cumulative area by composite Gauss rules,
//!   monotone inversion): [`Revolution`], [`GeneralizedCylinder`],
//!   [`TangentDevelopable`] (Appendix A.2), and bicubic [`BezierPatch`]es.
//! * [`mep`] — convex hull and minimal enclosing parallelogram of point sets and of
//!   boundaries with circular arcs (§3.2).
//! * [`DirectionMap`]s — hemisphere ↔ square (Glossy §3.3 [`GlossyHemisphere`],
//!   Shirley–Chiu [`ConcentricHemisphere`]) and sphere ↔ square
//!   ([`OctahedralSphere`]), with solid-angle Jacobians.
//!
//! All lengths are in world units and all maps are scale covariant (tested for sizes
//! 1e-4 … 1e4).

/// Generates the `equal_area`, `natural` and `with_kind` accessors shared by every
/// surface that stores its map as a `kind: ParamKind` field (one definition instead of a
/// copy per surface). The two literals are the doc lines of `equal_area` and `natural`.
macro_rules! map_kind_switch {
    ($equal_doc:literal, $natural_doc:literal) => {
        #[doc = $equal_doc]
        #[must_use]
        pub fn equal_area(&self) -> Self {
            self.with_kind(ParamKind::EqualArea)
        }
        #[doc = $natural_doc]
        #[must_use]
        pub fn natural(&self) -> Self {
            self.with_kind(ParamKind::Natural)
        }
        /// The same patch with the given map.
        #[must_use]
        pub fn with_kind(&self, kind: ParamKind) -> Self {
            Self {
                kind,
                ..self.clone()
            }
        }
    };
}
pub(crate) use map_kind_switch;

mod bezier_patch;
mod curves;
mod direction;
mod error;
mod flat;
mod frame;
pub mod mep;
mod numeric;
mod parallelogram;
mod quadrics;
mod spheroid;
mod surface;
mod torus;

pub use bezier_patch::BezierPatch;
pub use curves::{BezierCurve, Cardioid, Curve, Helix};
pub use direction::{
    ConcentricHemisphere, DirectionMap, GlossyHemisphere, OctahedralSphere,
    concentric_disc_to_square, concentric_square_to_disc,
};
pub use error::ParamError;
pub use flat::{GeneralizedCylinder, Revolution, TangentDevelopable};
pub use frame::{Aabb, Frame, SurfacePoint};
/// The vector types of the public API (`DVec2`, `DVec3`), re-exported.
pub use glam;
pub use mep::{
    BoundarySegment, convex_hull, min_enclosing_parallelogram,
    min_enclosing_parallelogram_of_boundary,
};
pub use parallelogram::{Parallelogram, Parallelogram2};
pub use quadrics::{Cone, Cylinder, Sphere};
pub use spheroid::Spheroid;
pub use surface::{ParamKind, Parametrization, SurfaceShape};
pub use torus::Torus;
