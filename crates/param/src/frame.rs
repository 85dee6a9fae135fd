//! Local orthonormal frames, axis-aligned boxes, surface samples and small angle and
//! interval helpers shared by the surfaces.

use crate::error::{ParamError, finite3};
use glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};

/// A right-handed orthonormal frame: every surface is defined in its local coordinates
/// (axis of revolution = local z) and placed in the world by this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    origin: DVec3,
    x: DVec3,
    y: DVec3,
    z: DVec3,
}

impl Default for Frame {
    fn default() -> Self {
        Self::canonical()
    }
}

impl Frame {
    /// The world frame (origin 0, axes x, y, z).
    pub fn canonical() -> Self {
        Self {
            origin: DVec3::ZERO,
            x: DVec3::X,
            y: DVec3::Y,
            z: DVec3::Z,
        }
    }

    /// The world axes translated to `origin`.
    ///
    /// # Errors
    /// [`ParamError::NonFinite`] for a non-finite origin.
    pub fn at(origin: DVec3) -> Result<Self, ParamError> {
        finite3("frame origin", origin)?;
        Ok(Self {
            origin,
            ..Self::canonical()
        })
    }

    /// A frame with local z along `axis` and local x along the part of `reference`
    /// orthogonal to `axis` (Gram–Schmidt); y = z × x.
    ///
    /// # Errors
    /// Non-finite inputs, a zero axis, or a reference parallel to the axis.
    pub fn new(origin: DVec3, axis: DVec3, reference: DVec3) -> Result<Self, ParamError> {
        finite3("frame origin", origin)?;
        finite3("frame axis", axis)?;
        finite3("frame reference", reference)?;
        let z = axis
            .try_normalize()
            .ok_or(ParamError::Degenerate("zero frame axis"))?;
        let r = reference - z * reference.dot(z);
        if r.length() <= 1e-12 * reference.length() || reference.length() == 0.0 {
            return Err(ParamError::Degenerate(
                "frame reference parallel to the axis",
            ));
        }
        let x = r.normalize();
        let y = z.cross(x);
        Ok(Self { origin, x, y, z })
    }

    /// A frame with local z along `axis` and some x orthogonal to it (Duff et al. 2017
    /// branchless basis; deterministic).
    ///
    /// # Errors
    /// Non-finite inputs or a zero axis.
    pub fn from_axis(origin: DVec3, axis: DVec3) -> Result<Self, ParamError> {
        finite3("frame origin", origin)?;
        finite3("frame axis", axis)?;
        let z = axis
            .try_normalize()
            .ok_or(ParamError::Degenerate("zero frame axis"))?;
        let (x, y) = z.any_orthonormal_pair();
        Ok(Self { origin, x, y, z })
    }

    /// Origin (world coordinates).
    pub fn origin(&self) -> DVec3 {
        self.origin
    }
    /// Local x axis (unit, world coordinates).
    pub fn x_axis(&self) -> DVec3 {
        self.x
    }
    /// Local y axis (unit, world coordinates).
    pub fn y_axis(&self) -> DVec3 {
        self.y
    }
    /// Local z axis (unit, world coordinates); the axis of revolution of round surfaces.
    pub fn z_axis(&self) -> DVec3 {
        self.z
    }

    /// Local → world for a point.
    #[inline]
    pub fn point_to_world(&self, p: DVec3) -> DVec3 {
        self.origin + self.vector_to_world(p)
    }
    /// Local → world for a direction.
    #[inline]
    pub fn vector_to_world(&self, v: DVec3) -> DVec3 {
        self.x * v.x + self.y * v.y + self.z * v.z
    }
    /// World → local for a point.
    #[inline]
    pub fn point_to_local(&self, p: DVec3) -> DVec3 {
        self.vector_to_local(p - self.origin)
    }
    /// World → local for a direction.
    #[inline]
    pub fn vector_to_local(&self, v: DVec3) -> DVec3 {
        DVec3::new(v.dot(self.x), v.dot(self.y), v.dot(self.z))
    }

    /// World box containing the local box `b` (conservative: the rotated box's AABB).
    pub fn box_to_world(&self, b: Aabb) -> Aabb {
        let c = (b.min + b.max) * 0.5;
        let e = (b.max - b.min) * 0.5;
        let wc = self.point_to_world(c);
        let we = self.x.abs() * e.x + self.y.abs() * e.y + self.z.abs() * e.z;
        Aabb {
            min: wc - we,
            max: wc + we,
        }
    }
}

/// An axis-aligned bounding box (world units).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Aabb {
    /// Lower corner.
    pub min: DVec3,
    /// Upper corner.
    pub max: DVec3,
}

impl Aabb {
    /// The empty box (min = +∞, max = −∞), identity for [`Aabb::union`].
    pub const EMPTY: Self = Self {
        min: DVec3::INFINITY,
        max: DVec3::NEG_INFINITY,
    };

    /// Box of a set of points.
    pub fn from_points(points: impl IntoIterator<Item = DVec3>) -> Self {
        points.into_iter().fold(Self::EMPTY, |b, p| b.grow(p))
    }

    /// The box enlarged to contain `p`.
    #[must_use]
    pub fn grow(self, p: DVec3) -> Self {
        Self {
            min: self.min.min(p),
            max: self.max.max(p),
        }
    }

    /// Smallest box containing both.
    #[must_use]
    pub fn union(self, o: Self) -> Self {
        Self {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Whether `p` lies inside the box enlarged by `tol` on every side.
    pub fn contains(&self, p: DVec3, tol: f64) -> bool {
        p.cmpge(self.min - tol).all() && p.cmple(self.max + tol).all()
    }

    /// Length of the diagonal.
    pub fn diagonal(&self) -> f64 {
        (self.max - self.min).length()
    }
}

/// A point of a parametrized surface with its first derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SurfacePoint {
    /// Position (world coordinates).
    pub position: DVec3,
    /// Unit normal (outward for closed surfaces; `dp_du × dp_dv` direction otherwise).
    pub normal: DVec3,
    /// ∂P/∂u (world units per unit u); may be non-finite at documented poles.
    pub dp_du: DVec3,
    /// ∂P/∂v (world units per unit v); may be non-finite at documented poles.
    pub dp_dv: DVec3,
}

impl SurfacePoint {
    /// `|∂P/∂u × ∂P/∂v|`, the area element from the tangents.
    pub fn tangent_jacobian(&self) -> f64 {
        self.dp_du.cross(self.dp_dv).length()
    }
}

/// Closed interval arithmetic helpers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Interval {
    pub lo: f64,
    pub hi: f64,
}

impl Interval {
    pub fn new(a: f64, b: f64) -> Self {
        Self {
            lo: a.min(b),
            hi: a.max(b),
        }
    }
    pub fn mul(self, o: Self) -> Self {
        let c = [
            self.lo * o.lo,
            self.lo * o.hi,
            self.hi * o.lo,
            self.hi * o.hi,
        ];
        Self {
            lo: c.iter().copied().fold(f64::INFINITY, f64::min),
            hi: c.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        }
    }
    pub fn add(self, o: Self) -> Self {
        Self {
            lo: self.lo + o.lo,
            hi: self.hi + o.hi,
        }
    }
    pub fn scale(self, s: f64) -> Self {
        Self::new(self.lo * s, self.hi * s)
    }
}

/// Whether some `c + 2kπ` lies in `[a0, a1]`.
pub(crate) fn angle_in(a0: f64, a1: f64, c: f64) -> bool {
    let k = ((a0 - c) / TAU).ceil();
    c + k * TAU <= a1
}

/// Range of cos over the angle interval `[a0, a1]`.
pub(crate) fn cos_range(a0: f64, a1: f64) -> Interval {
    let mut iv = Interval::new(a0.cos(), a1.cos());
    if angle_in(a0, a1, 0.0) {
        iv.hi = 1.0;
    }
    if angle_in(a0, a1, PI) {
        iv.lo = -1.0;
    }
    iv
}

/// Range of sin over the angle interval `[a0, a1]`.
pub(crate) fn sin_range(a0: f64, a1: f64) -> Interval {
    cos_range(a0 - PI / 2.0, a1 - PI / 2.0)
}

/// Box of a surface of revolution patch, local coordinates: radius ρ and height z
/// intervals swept over the azimuth interval.
pub(crate) fn revolution_box(theta: (f64, f64), rho: Interval, z: Interval) -> Aabb {
    let x = rho.mul(cos_range(theta.0, theta.1));
    let y = rho.mul(sin_range(theta.0, theta.1));
    Aabb {
        min: DVec3::new(x.lo, y.lo, z.lo),
        max: DVec3::new(x.hi, y.hi, z.hi),
    }
}

/// The representative of angle `a` (mod 2π) closest to the middle of `[a0, a1]`, so
/// that points just outside a patch get parameters just outside [0, 1] and the seam of
/// a full 2π range lies at its ends.
#[inline]
pub(crate) fn unwrap_angle(a: f64, a0: f64, a1: f64) -> f64 {
    let mid = 0.5 * (a0 + a1);
    let mut d = (a - mid).rem_euclid(TAU);
    if d >= PI {
        d -= TAU;
    }
    mid + d
}

/// `sqrt(1 - w²)` without cancellation near |w| = 1.
#[inline]
pub(crate) fn cos_from_sin(w: f64) -> f64 {
    ((1.0 - w) * (1.0 + w)).max(0.0).sqrt()
}

/// 2D cross product.
#[inline]
pub(crate) fn cross2(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}
