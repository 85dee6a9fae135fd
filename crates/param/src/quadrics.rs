//! Natural quadric patches with closed-form equal-area maps (VirtualMesh Appendix A.1):
//! right circular cylinder (natural coordinates already equal-area), circular cone
//! `(θ, φ²)` and sphere `(θ, sin φ)` (Archimedes; φ = latitude).
//!
//! Every patch lives in a [`Frame`] (axis = local z) and maps [0, 1]² onto an azimuth
//! range θ ∈ [θ0, θ1] (at most 2π) times a range of the second natural parameter.
//! The azimuth seam of a full 2π patch is at u = 0 ≡ 1.

use crate::error::{ParamError, angle_range, positive, range};
use crate::frame::{
    Aabb, Frame, Interval, SurfacePoint, cos_range, revolution_box, sin_range, unwrap_angle,
};
use crate::surface::{ParamKind, Parametrization, SurfaceShape, lerp};
use glam::{DVec2, DVec3};
use std::f64::consts::FRAC_PI_2;

/// A right circular cylinder patch: local `(r cos θ, r sin θ, z)`,
/// θ ∈ `theta`, z ∈ `height`. Natural coordinates are equal-area (Appendix A.1), so both
/// kinds give the same constant Jacobian `r·Δθ·Δz`.
#[derive(Debug, Clone, PartialEq)]
pub struct Cylinder {
    frame: Frame,
    radius: f64,
    theta: (f64, f64),
    height: (f64, f64),
    kind: ParamKind,
}

impl Cylinder {
    /// A cylinder patch of radius `radius` around the frame's z axis.
    ///
    /// # Errors
    /// Non-positive or non-finite radius, empty ranges, azimuth range over 2π.
    pub fn new(
        frame: Frame,
        radius: f64,
        theta: (f64, f64),
        height: (f64, f64),
    ) -> Result<Self, ParamError> {
        Ok(Self {
            frame,
            radius: positive("cylinder radius", radius)?,
            theta: angle_range("cylinder azimuth", theta)?,
            height: range("cylinder height", height)?,
            kind: ParamKind::EqualArea,
        })
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map.",
        "The same patch with the natural map (identical for a cylinder)."
    );
    /// Placement (axis = local z, θ measured from local x).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Azimuth range (radians).
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Height range along the local z axis.
    pub fn height_range(&self) -> (f64, f64) {
        self.height
    }
}

impl Parametrization for Cylinder {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let th = lerp(self.theta.0, self.theta.1, uv.x);
        let z = lerp(self.height.0, self.height.1, uv.y);
        let (s, c) = th.sin_cos();
        let f = &self.frame;
        let r = self.radius;
        SurfacePoint {
            position: f.point_to_world(DVec3::new(r * c, r * s, z)),
            normal: f.vector_to_world(DVec3::new(c, s, 0.0)),
            dp_du: f.vector_to_world(DVec3::new(-s, c, 0.0) * (r * (self.theta.1 - self.theta.0))),
            dp_dv: f.vector_to_world(DVec3::new(0.0, 0.0, self.height.1 - self.height.0)),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        if !q.is_finite() || (q.x == 0.0 && q.y == 0.0) {
            return None;
        }
        let th = unwrap_angle(q.y.atan2(q.x), self.theta.0, self.theta.1);
        Some(DVec2::new(
            (th - self.theta.0) / (self.theta.1 - self.theta.0),
            (q.z - self.height.0) / (self.height.1 - self.height.0),
        ))
    }
    fn jacobian(&self, _uv: DVec2) -> f64 {
        self.area()
    }
    fn area(&self) -> f64 {
        self.radius * (self.theta.1 - self.theta.0) * (self.height.1 - self.height.0)
    }
    fn bounds(&self) -> Aabb {
        let b = revolution_box(
            self.theta,
            Interval::new(self.radius, self.radius),
            Interval::new(self.height.0, self.height.1),
        );
        self.frame.box_to_world(b)
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn is_equal_area(&self) -> bool {
        true
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Cylinder(self)
    }
}

/// A circular cone patch with apex at the frame origin (VirtualMesh Appendix A.1):
/// local `(a φ cos θ, a φ sin θ, b φ)`, θ ∈ `theta`, φ ∈ `phi` with `0 ≤ φ0 < φ1`.
/// `a` is the radius and `b` the height at φ = 1. The equal-area map is linear in
/// `(θ, φ²)`, Jacobian `Δθ·a·√(a²+b²)·(φ1² − φ0²)/2`; the apex (φ0 = 0) is allowed
/// (its v-tangent is singular there). The normal points away from the axis.
#[derive(Debug, Clone, PartialEq)]
pub struct Cone {
    frame: Frame,
    a: f64,
    b: f64,
    slant: f64,
    theta: (f64, f64),
    phi: (f64, f64),
    kind: ParamKind,
}

impl Cone {
    /// A cone patch; `radius` and `height` are those of the cross-section at φ = 1.
    ///
    /// # Errors
    /// Non-positive radius or height, `φ0 < 0`, empty ranges, azimuth over 2π.
    pub fn new(
        frame: Frame,
        radius: f64,
        height: f64,
        theta: (f64, f64),
        phi: (f64, f64),
    ) -> Result<Self, ParamError> {
        let a = positive("cone radius", radius)?;
        let b = positive("cone height", height)?;
        let phi = range("cone generator parameter φ", phi)?;
        if phi.0 < 0.0 {
            return Err(ParamError::InvalidRange {
                what: "cone generator parameter φ",
                lo: phi.0,
                hi: phi.1,
                why: "one nappe: need φ0 >= 0",
            });
        }
        Ok(Self {
            frame,
            a,
            b,
            slant: a.hypot(b),
            theta: angle_range("cone azimuth", theta)?,
            phi,
            kind: ParamKind::EqualArea,
        })
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map `(θ, φ²)`.",
        "The same patch with the natural map `(θ, φ)`."
    );
    /// Placement: apex at the origin, axis = local z.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Apex (world).
    pub fn apex(&self) -> DVec3 {
        self.frame.origin()
    }
    /// Radius `a` at φ = 1.
    pub fn radius(&self) -> f64 {
        self.a
    }
    /// Height `b` at φ = 1.
    pub fn height(&self) -> f64 {
        self.b
    }
    /// Half-angle at the apex, `atan(a / b)` (radians).
    pub fn half_angle(&self) -> f64 {
        self.a.atan2(self.b)
    }
    /// Azimuth range (radians).
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Range of φ (fraction of the unit-height cross-section).
    pub fn phi_range(&self) -> (f64, f64) {
        self.phi
    }

    fn phi_of(&self, t: f64) -> (f64, f64) {
        let (p0, p1) = self.phi;
        match self.kind {
            ParamKind::Natural => (lerp(p0, p1, t), p1 - p0),
            ParamKind::EqualArea => {
                let sq = lerp(p0 * p0, p1 * p1, t).max(0.0);
                let phi = sq.sqrt();
                (phi, (p1 * p1 - p0 * p0) / (2.0 * phi))
            }
        }
    }
}

impl Parametrization for Cone {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let th = lerp(self.theta.0, self.theta.1, uv.x);
        let (phi, dphi_dt) = self.phi_of(uv.y);
        let (s, c) = th.sin_cos();
        let f = &self.frame;
        let (a, b) = (self.a, self.b);
        SurfacePoint {
            position: f.point_to_world(DVec3::new(a * phi * c, a * phi * s, b * phi)),
            normal: f.vector_to_world(DVec3::new(b * c, b * s, -a) / self.slant),
            dp_du: f.vector_to_world(
                DVec3::new(-s, c, 0.0) * (a * phi * (self.theta.1 - self.theta.0)),
            ),
            dp_dv: f.vector_to_world(DVec3::new(a * c, a * s, b) * dphi_dt),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        if !q.is_finite() || (q.x == 0.0 && q.y == 0.0) {
            return None;
        }
        let rho = q.x.hypot(q.y);
        // Foot of the perpendicular on the generator through (ρ, z).
        let phi = (self.a * rho + self.b * q.z) / (self.slant * self.slant);
        let th = unwrap_angle(q.y.atan2(q.x), self.theta.0, self.theta.1);
        let (p0, p1) = self.phi;
        let t = match self.kind {
            ParamKind::Natural => (phi - p0) / (p1 - p0),
            ParamKind::EqualArea => (phi * phi.abs() - p0 * p0) / (p1 * p1 - p0 * p0),
        };
        Some(DVec2::new(
            (th - self.theta.0) / (self.theta.1 - self.theta.0),
            t,
        ))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        let dth = self.theta.1 - self.theta.0;
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let phi = lerp(self.phi.0, self.phi.1, uv.y);
                dth * (self.phi.1 - self.phi.0) * self.a * phi * self.slant
            }
        }
    }
    fn area(&self) -> f64 {
        let (p0, p1) = self.phi;
        (self.theta.1 - self.theta.0) * self.a * self.slant * (p1 - p0) * (p1 + p0) * 0.5
    }
    fn bounds(&self) -> Aabb {
        let (p0, p1) = self.phi;
        let b = revolution_box(
            self.theta,
            Interval::new(self.a * p0, self.a * p1),
            Interval::new(self.b * p0, self.b * p1),
        );
        self.frame.box_to_world(b)
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Cone(self)
    }
}

/// A sphere patch: local `R (cos φ cos θ, cos φ sin θ, sin φ)` with latitude
/// φ ∈ `latitude` ⊆ [−π/2, π/2] and azimuth θ ∈ `theta`. The equal-area map is linear
/// in `(θ, sin φ)` (VirtualMesh Appendix A.1, the e → 0 limit of the spheroid; the
/// appendix writes z = b cos φ but its equal-area coordinate sin φ is that of the
/// latitude convention used here). Jacobian `R²·Δθ·(sin φ1 − sin φ0)`.
///
/// Internally the equal-area coordinate is held as the distance `m = 1 ∓ sin φ` from
/// the nearer pole so that small polar caps keep full relative precision. At the poles
/// the v-tangent is singular and θ is undefined (documented pole).
#[derive(Debug, Clone, PartialEq)]
pub struct Sphere {
    frame: Frame,
    radius: f64,
    theta: (f64, f64),
    lat: (f64, f64),
    /// +1: m measured from the north pole (m = 1 − sin φ); −1: from the south pole.
    pole: f64,
    m0: f64,
    m1: f64,
    kind: ParamKind,
}

/// `1 − σ sin φ` computed without cancellation: `2 sin²((π/2 − σφ)/2)`.
fn pole_distance(sigma: f64, phi: f64) -> f64 {
    let h = (FRAC_PI_2 - sigma * phi) * 0.5;
    let s = h.sin();
    2.0 * s * s
}

impl Sphere {
    /// A sphere patch centred at the frame origin.
    ///
    /// # Errors
    /// Non-positive radius, latitude range outside [−π/2, π/2] or empty, azimuth range
    /// empty or over 2π.
    pub fn new(
        frame: Frame,
        radius: f64,
        theta: (f64, f64),
        latitude: (f64, f64),
    ) -> Result<Self, ParamError> {
        let radius = positive("sphere radius", radius)?;
        let theta = angle_range("sphere azimuth", theta)?;
        let lat = latitude_range("sphere latitude", latitude)?;
        let pole = if lat.0 + lat.1 >= 0.0 { 1.0 } else { -1.0 };
        Ok(Self {
            frame,
            radius,
            theta,
            lat,
            pole,
            m0: pole_distance(pole, lat.0),
            m1: pole_distance(pole, lat.1),
            kind: ParamKind::EqualArea,
        })
    }
    /// The whole sphere (seam at θ = ±π, poles at v = 0 and 1).
    ///
    /// # Errors
    /// Non-positive radius.
    pub fn full(frame: Frame, radius: f64) -> Result<Self, ParamError> {
        use std::f64::consts::PI;
        Self::new(frame, radius, (-PI, PI), (-FRAC_PI_2, FRAC_PI_2))
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map `(θ, sin φ)`.",
        "The same patch with the natural map `(θ, φ)`."
    );
    /// Placement (centre = origin, poles on local ±z).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Centre (world).
    pub fn centre(&self) -> DVec3 {
        self.frame.origin()
    }
    /// Radius.
    pub fn radius(&self) -> f64 {
        self.radius
    }
    /// Azimuth range (radians).
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Latitude range (radians).
    pub fn latitude_range(&self) -> (f64, f64) {
        self.lat
    }

    /// (cos φ, sin φ, d(local point)/dv factor) for the second parameter `t`.
    fn lat_of(&self, t: f64) -> (f64, f64, DVec3Fn) {
        match self.kind {
            ParamKind::Natural => {
                let phi = lerp(self.lat.0, self.lat.1, t);
                let (w, c) = phi.sin_cos();
                (c, w, DVec3Fn::Natural(self.lat.1 - self.lat.0))
            }
            ParamKind::EqualArea => {
                let m = lerp(self.m0, self.m1, t).clamp(0.0, 2.0);
                let w = self.pole * (1.0 - m);
                let c = (m * (2.0 - m)).sqrt();
                (c, w, DVec3Fn::EqualArea(-self.pole * (self.m1 - self.m0)))
            }
        }
    }
}

/// How the latitude tangent scales.
enum DVec3Fn {
    /// dφ/dt.
    Natural(f64),
    /// d(sin φ)/dt.
    EqualArea(f64),
}

pub(crate) fn latitude_range(what: &'static str, r: (f64, f64)) -> Result<(f64, f64), ParamError> {
    let (lo, hi) = range(what, r)?;
    let lim = FRAC_PI_2 * (1.0 + 4.0 * f64::EPSILON);
    if lo < -lim || hi > lim {
        return Err(ParamError::InvalidRange {
            what,
            lo,
            hi,
            why: "latitudes lie in [-π/2, π/2]",
        });
    }
    Ok((lo.max(-FRAC_PI_2), hi.min(FRAC_PI_2)))
}

impl Parametrization for Sphere {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let th = lerp(self.theta.0, self.theta.1, uv.x);
        let (s, c) = th.sin_cos();
        let (cp, sp, dv) = self.lat_of(uv.y);
        let n = DVec3::new(cp * c, cp * s, sp);
        let r = self.radius;
        let dlat = match dv {
            DVec3Fn::Natural(dphi) => DVec3::new(-sp * c, -sp * s, cp) * (r * dphi),
            DVec3Fn::EqualArea(dw) => DVec3::new(-sp / cp * c, -sp / cp * s, 1.0) * (r * dw),
        };
        let f = &self.frame;
        SurfacePoint {
            position: f.point_to_world(n * r),
            normal: f.vector_to_world(n),
            dp_du: f
                .vector_to_world(DVec3::new(-s, c, 0.0) * (r * cp * (self.theta.1 - self.theta.0))),
            dp_dv: f.vector_to_world(dlat),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        let len = q.length();
        if !q.is_finite() || len == 0.0 {
            return None;
        }
        let th = if q.x == 0.0 && q.y == 0.0 {
            // Pole: any azimuth; take the patch's middle.
            0.5 * (self.theta.0 + self.theta.1)
        } else {
            unwrap_angle(q.y.atan2(q.x), self.theta.0, self.theta.1)
        };
        let u = (th - self.theta.0) / (self.theta.1 - self.theta.0);
        let rho = q.x.hypot(q.y);
        let v = match self.kind {
            ParamKind::Natural => (q.z.atan2(rho) - self.lat.0) / (self.lat.1 - self.lat.0),
            ParamKind::EqualArea => {
                let sz = self.pole * q.z;
                let m = if sz > 0.0 {
                    rho * rho / (len * (len + sz))
                } else {
                    1.0 - sz / len
                };
                (m - self.m0) / (self.m1 - self.m0)
            }
        };
        Some(DVec2::new(u, v))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let phi = lerp(self.lat.0, self.lat.1, uv.y);
                self.radius
                    * self.radius
                    * (self.theta.1 - self.theta.0)
                    * (self.lat.1 - self.lat.0)
                    * phi.cos()
            }
        }
    }
    fn area(&self) -> f64 {
        self.radius * self.radius * (self.theta.1 - self.theta.0) * (self.m1 - self.m0).abs()
    }
    fn bounds(&self) -> Aabb {
        let rho = cos_range(self.lat.0, self.lat.1).scale(self.radius);
        let z = sin_range(self.lat.0, self.lat.1).scale(self.radius);
        self.frame.box_to_world(revolution_box(self.theta, rho, z))
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Sphere(self)
    }
}
