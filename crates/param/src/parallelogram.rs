//! Planar parallelograms: the affine map Λ(ũ, ṽ) = A + ũ·AB + ṽ·AD of VirtualMesh §3.3,
//! whose Jacobian is constant (the parallelogram's area). Used directly as planar
//! patches and as the virtual support of complex polygons (see [`crate::mep`]).

use crate::error::{ParamError, finite3};
use crate::frame::{Aabb, Frame, SurfacePoint};
use crate::surface::{ParamKind, Parametrization, SurfaceShape};
use glam::{DVec2, DVec3};

/// A parallelogram `origin + u·e1 + v·e2`, `(u, v) ∈ [0, 1]²`, normal `e1 × e2`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parallelogram {
    origin: DVec3,
    e1: DVec3,
    e2: DVec3,
    normal: DVec3,
    area: f64,
    /// Dual basis: u = (p − origin)·d1, v = (p − origin)·d2.
    d1: DVec3,
    d2: DVec3,
}

impl Parallelogram {
    /// Builds the parallelogram with corner `origin` and edges `e1`, `e2`.
    ///
    /// Works for any positive angle between the edges that rounding can resolve
    /// (tested down to 1e-6 rad).
    ///
    /// # Errors
    /// Non-finite input, or edges that are zero or parallel to rounding
    /// (`|e1 × e2| ≤ 8ε·|e1||e2|`).
    pub fn new(origin: DVec3, e1: DVec3, e2: DVec3) -> Result<Self, ParamError> {
        finite3("parallelogram origin", origin)?;
        finite3("parallelogram edge e1", e1)?;
        finite3("parallelogram edge e2", e2)?;
        let c = e1.cross(e2);
        let area = c.length();
        if area <= 8.0 * f64::EPSILON * e1.length() * e2.length() || !area.is_finite() {
            return Err(ParamError::Degenerate(
                "parallelogram edges are parallel or zero",
            ));
        }
        let normal = c / area;
        Ok(Self {
            origin,
            e1,
            e2,
            normal,
            area,
            d1: e2.cross(normal) / area,
            d2: normal.cross(e1) / area,
        })
    }

    /// The parallelogram with vertices A, B, C = B + D − A, D (VirtualMesh §3.3).
    ///
    /// # Errors
    /// As [`Parallelogram::new`].
    pub fn from_corners(a: DVec3, b: DVec3, d: DVec3) -> Result<Self, ParamError> {
        Self::new(a, b - a, d - a)
    }

    /// Lifts a planar parallelogram (e.g. a minimal enclosing parallelogram) into the
    /// plane z = 0 of `frame`.
    ///
    /// # Errors
    /// As [`Parallelogram::new`].
    pub fn from_planar(frame: &Frame, p: &Parallelogram2) -> Result<Self, ParamError> {
        let lift = |v: DVec2| frame.vector_to_world(DVec3::new(v.x, v.y, 0.0));
        Self::new(
            frame.point_to_world(DVec3::new(p.origin.x, p.origin.y, 0.0)),
            lift(p.e1),
            lift(p.e2),
        )
    }

    /// Corner A.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }
    /// Edge AB.
    pub fn e1(&self) -> DVec3 {
        self.e1
    }
    /// Edge AD.
    pub fn e2(&self) -> DVec3 {
        self.e2
    }
    /// Unit normal `(e1 × e2)/|e1 × e2|`.
    pub fn unit_normal(&self) -> DVec3 {
        self.normal
    }
    /// The four corners A, B, C, D in order.
    pub fn corners(&self) -> [DVec3; 4] {
        let o = self.origin;
        [o, o + self.e1, o + self.e1 + self.e2, o + self.e2]
    }
    /// Affine coordinates of the projection of `p` onto the plane.
    #[inline]
    pub fn coordinates(&self, p: DVec3) -> DVec2 {
        let d = p - self.origin;
        DVec2::new(d.dot(self.d1), d.dot(self.d2))
    }
}

impl Parametrization for Parallelogram {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        SurfacePoint {
            position: self.origin + self.e1 * uv.x + self.e2 * uv.y,
            normal: self.normal,
            dp_du: self.e1,
            dp_dv: self.e2,
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        p.is_finite().then(|| self.coordinates(p))
    }
    fn jacobian(&self, _uv: DVec2) -> f64 {
        self.area
    }
    fn area(&self) -> f64 {
        self.area
    }
    fn bounds(&self) -> Aabb {
        Aabb::from_points(self.corners())
    }
    fn kind(&self) -> ParamKind {
        ParamKind::EqualArea
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Parallelogram(self)
    }
}

/// A parallelogram in the plane: `origin + u·e1 + v·e2`, `(u, v) ∈ [0, 1]²`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Parallelogram2 {
    /// Corner A.
    pub origin: DVec2,
    /// Edge AB.
    pub e1: DVec2,
    /// Edge AD.
    pub e2: DVec2,
}

impl Parallelogram2 {
    /// Area `|e1 × e2|`.
    pub fn area(&self) -> f64 {
        crate::frame::cross2(self.e1, self.e2).abs()
    }
    /// Corners A, B, C, D.
    pub fn corners(&self) -> [DVec2; 4] {
        let o = self.origin;
        [o, o + self.e1, o + self.e1 + self.e2, o + self.e2]
    }
    /// Point at affine coordinates `uv` (Λ of VirtualMesh §3.3).
    pub fn point(&self, uv: DVec2) -> DVec2 {
        self.origin + self.e1 * uv.x + self.e2 * uv.y
    }
    /// Affine coordinates of `p` (Λ⁻¹); non-finite for a degenerate parallelogram.
    pub fn coordinates(&self, p: DVec2) -> DVec2 {
        let d = p - self.origin;
        let c = crate::frame::cross2(self.e1, self.e2);
        DVec2::new(
            crate::frame::cross2(d, self.e2) / c,
            crate::frame::cross2(self.e1, d) / c,
        )
    }
    /// Whether `p` lies in the parallelogram, with slack `tol` in affine coordinates.
    pub fn contains(&self, p: DVec2, tol: f64) -> bool {
        let c = self.coordinates(p);
        c.x >= -tol && c.x <= 1.0 + tol && c.y >= -tol && c.y <= 1.0 + tol
    }
}
