//! The parametrized-surface trait: a map from the unit square [0, 1]² onto a surface
//! patch, its inverse, Jacobian (area element), area and bounds, with natural and
//! equal-area (constant-Jacobian, VirtualMesh §3 eq. (1)) parametrizations side by side.

use crate::frame::{Aabb, SurfacePoint};
use glam::{DVec2, DVec3};

/// Which parametrization of a surface patch a map uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum ParamKind {
    /// Constant-Jacobian ("energy-preserving", VirtualMesh §3): equal parameter areas
    /// map to equal surface areas; [`Parametrization::jacobian`] equals the patch area.
    #[default]
    EqualArea,
    /// The natural parameters (angles, heights, curve parameters) stretched linearly
    /// onto [0, 1]²; in general the Jacobian varies (kept for the VirtualMesh Table 3
    /// comparison and for Fig. 4).
    Natural,
}

/// A map Ψ from the unit square onto a surface patch (VirtualMesh §3.1, composed with
/// the affine Λ of §3.3 so that the domain is always [0, 1]²).
///
/// Object safe: scenes keep `Vec<Box<dyn Parametrization>>`.
pub trait Parametrization: Send + Sync + std::fmt::Debug {
    /// Position, unit normal and tangents at `uv` (world coordinates). Defined for all
    /// finite `uv`; values outside [0, 1]² extend the patch analytically where possible.
    fn eval(&self, uv: DVec2) -> SurfacePoint;

    /// Position at `uv`.
    fn position(&self, uv: DVec2) -> DVec3 {
        self.eval(uv).position
    }

    /// Unit normal at `uv`.
    fn normal(&self, uv: DVec2) -> DVec3 {
        self.eval(uv).normal
    }

    /// Parameters of the point of the (untrimmed, unbounded where meaningful) surface
    /// nearest to `p` — exact for points on the surface. The result may lie outside
    /// [0, 1]², meaning `p` is not on this patch. `None` for non-finite input or where
    /// the parameters are undefined (e.g. a point on the axis of a cylinder).
    fn inverse(&self, p: DVec3) -> Option<DVec2>;

    /// Area element `|∂P/∂u × ∂P/∂v|` at `uv` (world area per unit parameter area);
    /// constant and equal to [`Parametrization::area`] for equal-area maps.
    fn jacobian(&self, uv: DVec2) -> f64;

    /// Area of the patch (world units²).
    fn area(&self) -> f64;

    /// A box containing the patch (conservative; tight for axis-aligned frames).
    fn bounds(&self) -> Aabb;

    /// Which parametrization this map uses.
    fn kind(&self) -> ParamKind;

    /// Whether the Jacobian is constant (VirtualMesh's energy-preserving property).
    /// Surfaces whose natural map is already equal-area (plane, cylinder) report true
    /// for both kinds.
    fn is_equal_area(&self) -> bool {
        self.kind() == ParamKind::EqualArea
    }

    /// The concrete surface, for analytic ray intersection and shape parameters.
    fn shape(&self) -> SurfaceShape<'_>;
}

/// The concrete surface behind a [`Parametrization`] (for analytic intersection code
/// that needs shape parameters).
#[derive(Debug, Clone, Copy)]
#[non_exhaustive]
pub enum SurfaceShape<'a> {
    /// Planar parallelogram (VirtualMesh §3.3).
    Parallelogram(&'a crate::Parallelogram),
    /// Right circular cylinder patch.
    Cylinder(&'a crate::Cylinder),
    /// Circular cone patch.
    Cone(&'a crate::Cone),
    /// Sphere patch.
    Sphere(&'a crate::Sphere),
    /// Prolate or oblate spheroid patch.
    Spheroid(&'a crate::Spheroid),
    /// Ring torus patch.
    Torus(&'a crate::Torus),
    /// General surface of revolution.
    Revolution(&'a crate::Revolution),
    /// Generalized cylinder.
    GeneralizedCylinder(&'a crate::GeneralizedCylinder),
    /// Tangent developable.
    TangentDevelopable(&'a crate::TangentDevelopable),
    /// Bicubic Bézier patch.
    BezierPatch(&'a crate::BezierPatch),
}

/// Linear map of `s ∈ [0, 1]` onto `[a, b]`.
#[inline]
pub(crate) fn lerp(a: f64, b: f64, s: f64) -> f64 {
    a + (b - a) * s
}
