//! Numerically reparametrized surfaces (VirtualMesh §3.1.2 eq. (2), Appendix A.2):
//! general surfaces of revolution, generalized cylinders and tangent developables.
//!
//! Each has a separable equal-area map: one parameter stays linear (azimuth, ruling
//! length, or its square for developables) and the other is the normalised cumulative
//! area along the curve, `C(t)/C(t1)`, with `C` tabulated by composite Gauss–Legendre
//! rules (32 panels × 10 points) and inverted by bracketed Newton (C' = density ≥ 0).
//! Inverses from points use closest-point iterations (Newton on the profile for
//! surfaces of revolution, damped Gauss–Newton otherwise).

use crate::curves::Curve;
use crate::error::{ParamError, angle_range, finite3, range};
use crate::frame::{Aabb, Frame, Interval, SurfacePoint, revolution_box, unwrap_angle};
use crate::numeric::{Cumulative, closest_on_curve, closest_point};
use crate::surface::{ParamKind, Parametrization, SurfaceShape, lerp};
use glam::{DVec2, DVec3};
use std::sync::Arc;

const PANELS: usize = 32;
const ORDER: usize = 10;

/// Validates a density on samples of `[t0, t1]`: finite, non-negative, positive total.
fn check_density(
    t: (f64, f64),
    what: &'static str,
    rho: impl Fn(f64) -> f64,
) -> Result<(), ParamError> {
    let mut any = false;
    for i in 0..=64 {
        let x = lerp(t.0, t.1, i as f64 / 64.0);
        let r = rho(x);
        if !r.is_finite() {
            return Err(ParamError::NonFinite { what });
        }
        if r < 0.0 {
            return Err(ParamError::Degenerate(what));
        }
        any |= r > 0.0;
    }
    if any {
        Ok(())
    } else {
        Err(ParamError::Degenerate(what))
    }
}

/// A surface of revolution about the frame's z axis: profile curve `c(t)`, t ∈
/// `t_range`, read in the local xz half-plane (radius = c.x ≥ 0, height = c.z; c.y is
/// ignored), swept over θ ∈ `theta`. Equal-area map: θ linear, v = C(t)/C(t1) with
/// density `c.x(t)·|(c.x', c.z')(t)|`. Points of the profile on the axis are poles.
#[derive(Debug, Clone)]
pub struct Revolution {
    frame: Frame,
    profile: Arc<dyn Curve>,
    t: (f64, f64),
    theta: (f64, f64),
    table: Arc<Cumulative>,
    kind: ParamKind,
}

impl Revolution {
    /// A surface of revolution patch.
    ///
    /// # Errors
    /// Empty ranges, azimuth over 2π, a profile with negative radius, non-finite
    /// values or zero area.
    pub fn new(
        frame: Frame,
        profile: Arc<dyn Curve>,
        t_range: (f64, f64),
        theta: (f64, f64),
    ) -> Result<Self, ParamError> {
        let t = range("profile parameter range", t_range)?;
        let theta = angle_range("revolution azimuth", theta)?;
        let rho = |x: f64| density_rev(profile.as_ref(), x);
        check_density(t, "profile must have radius >= 0 and positive area", rho)?;
        let table = Arc::new(Cumulative::new(t.0, t.1, PANELS, ORDER, rho));
        Ok(Self {
            frame,
            profile,
            t,
            theta,
            table,
            kind: ParamKind::EqualArea,
        })
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map.",
        "The same patch with the natural map `(θ, t)`."
    );
    /// Placement (axis = local z).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Profile curve (local xz half-plane).
    pub fn profile(&self) -> &Arc<dyn Curve> {
        &self.profile
    }
    /// Profile parameter range.
    pub fn t_range(&self) -> (f64, f64) {
        self.t
    }
    /// Azimuth range.
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    fn density(&self, t: f64) -> f64 {
        density_rev(self.profile.as_ref(), t)
    }
    /// (t, dt/dv) for the second unit-square coordinate.
    fn t_of(&self, v: f64) -> (f64, f64) {
        match self.kind {
            ParamKind::Natural => (lerp(self.t.0, self.t.1, v), self.t.1 - self.t.0),
            ParamKind::EqualArea => {
                let total = self.table.total();
                let t = self.table.inverse(v * total, |x| self.density(x));
                (t, total / self.density(t))
            }
        }
    }
}

fn density_rev(c: &dyn Curve, t: f64) -> f64 {
    let p = c.point(t);
    let d = c.d1(t);
    p.x * d.x.hypot(d.z)
}

impl Parametrization for Revolution {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let th = lerp(self.theta.0, self.theta.1, uv.x);
        let (s, c) = th.sin_cos();
        let (t, dtdv) = self.t_of(uv.y);
        let p = self.profile.point(t);
        let d = self.profile.d1(t);
        let f = &self.frame;
        SurfacePoint {
            position: f.point_to_world(DVec3::new(p.x * c, p.x * s, p.z)),
            normal: f.vector_to_world(DVec3::new(c * d.z, s * d.z, -d.x) / d.x.hypot(d.z)),
            dp_du: f
                .vector_to_world(DVec3::new(-s, c, 0.0) * (p.x * (self.theta.1 - self.theta.0))),
            dp_dv: f.vector_to_world(DVec3::new(d.x * c, d.x * s, d.z) * dtdv),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        if !q.is_finite() {
            return None;
        }
        let rho = q.x.hypot(q.y);
        let th = if rho == 0.0 {
            0.5 * (self.theta.0 + self.theta.1)
        } else {
            unwrap_angle(q.y.atan2(q.x), self.theta.0, self.theta.1)
        };
        let prof = self.profile.as_ref();
        let t = closest_on_curve(self.t.0, self.t.1, 64, DVec2::new(rho, q.z), |t| {
            let (a, b, c) = (prof.point(t), prof.d1(t), prof.d2(t));
            (
                DVec2::new(a.x, a.z),
                DVec2::new(b.x, b.z),
                DVec2::new(c.x, c.z),
            )
        });
        let v = match self.kind {
            ParamKind::Natural => (t - self.t.0) / (self.t.1 - self.t.0),
            ParamKind::EqualArea => self.table.value(t, |x| self.density(x)) / self.table.total(),
        };
        Some(DVec2::new(
            (th - self.theta.0) / (self.theta.1 - self.theta.0),
            v,
        ))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let t = lerp(self.t.0, self.t.1, uv.y);
                (self.theta.1 - self.theta.0) * (self.t.1 - self.t.0) * self.density(t)
            }
        }
    }
    fn area(&self) -> f64 {
        (self.theta.1 - self.theta.0) * self.table.total()
    }
    fn bounds(&self) -> Aabb {
        let b = self.profile.bounds(self.t.0, self.t.1);
        let rho = Interval::new(b.min.x.max(0.0), b.max.x.max(0.0));
        let z = Interval::new(b.min.z, b.max.z);
        self.frame.box_to_world(revolution_box(self.theta, rho, z))
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Revolution(self)
    }
}

/// A generalized cylinder `x(θ, φ) = y(θ) + φ p` (VirtualMesh Appendix A.2), base curve
/// y over θ ∈ `theta`, ruling direction p (local coordinates), φ ∈ `phi`. Equal-area:
/// u = S(θ)/S(θ1) with density `|y'(θ) × p|`, v linear in φ.
#[derive(Debug, Clone)]
pub struct GeneralizedCylinder {
    frame: Frame,
    base: Arc<dyn Curve>,
    dir: DVec3,
    theta: (f64, f64),
    phi: (f64, f64),
    table: Arc<Cumulative>,
    kind: ParamKind,
}

impl GeneralizedCylinder {
    /// A generalized cylinder patch.
    ///
    /// # Errors
    /// Empty ranges, zero or non-finite direction, or a base curve parallel to the
    /// rulings (zero area).
    pub fn new(
        frame: Frame,
        base: Arc<dyn Curve>,
        direction: DVec3,
        theta: (f64, f64),
        phi: (f64, f64),
    ) -> Result<Self, ParamError> {
        let dir = finite3("ruling direction", direction)?;
        if dir == DVec3::ZERO {
            return Err(ParamError::Degenerate("zero ruling direction"));
        }
        let theta = range("base curve parameter range", theta)?;
        let phi = range("ruling parameter range", phi)?;
        let rho = |x: f64| base.d1(x).cross(dir).length();
        check_density(theta, "base curve parallel to the rulings", rho)?;
        let table = Arc::new(Cumulative::new(theta.0, theta.1, PANELS, ORDER, rho));
        Ok(Self {
            frame,
            base,
            dir,
            theta,
            phi,
            table,
            kind: ParamKind::EqualArea,
        })
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map.",
        "The same patch with the natural map `(θ, φ)`."
    );
    /// Placement.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Base curve (local coordinates).
    pub fn base(&self) -> &Arc<dyn Curve> {
        &self.base
    }
    /// Ruling direction p (local coordinates).
    pub fn direction(&self) -> DVec3 {
        self.dir
    }
    /// Base-curve parameter range.
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Ruling parameter range.
    pub fn phi_range(&self) -> (f64, f64) {
        self.phi
    }
    fn density(&self, t: f64) -> f64 {
        self.base.d1(t).cross(self.dir).length()
    }
    fn theta_of(&self, u: f64) -> (f64, f64) {
        theta_of(self.kind, &self.table, self.theta, u, |x| self.density(x))
    }
    fn u_of(&self, th: f64) -> f64 {
        u_of(self.kind, &self.table, self.theta, th, |x| self.density(x))
    }
}

fn theta_of(
    kind: ParamKind,
    table: &Cumulative,
    theta: (f64, f64),
    u: f64,
    rho: impl Fn(f64) -> f64,
) -> (f64, f64) {
    match kind {
        ParamKind::Natural => (lerp(theta.0, theta.1, u), theta.1 - theta.0),
        ParamKind::EqualArea => {
            let total = table.total();
            let th = table.inverse(u * total, &rho);
            (th, total / rho(th))
        }
    }
}

fn u_of(
    kind: ParamKind,
    table: &Cumulative,
    theta: (f64, f64),
    th: f64,
    rho: impl Fn(f64) -> f64,
) -> f64 {
    match kind {
        ParamKind::Natural => (th - theta.0) / (theta.1 - theta.0),
        ParamKind::EqualArea => table.value(th, rho) / table.total(),
    }
}

impl Parametrization for GeneralizedCylinder {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let (th, dth) = self.theta_of(uv.x);
        let phi = lerp(self.phi.0, self.phi.1, uv.y);
        let y = self.base.point(th);
        let d = self.base.d1(th);
        let f = &self.frame;
        SurfacePoint {
            position: f.point_to_world(y + self.dir * phi),
            normal: f.vector_to_world(d.cross(self.dir).normalize()),
            dp_du: f.vector_to_world(d * dth),
            dp_dv: f.vector_to_world(self.dir * (self.phi.1 - self.phi.0)),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        let lo = DVec2::new(self.theta.0, self.phi.0);
        let hi = DVec2::new(self.theta.1, self.phi.1);
        let nat = closest_point(lo, hi, 16, q, |a| {
            (
                self.base.point(a.x) + self.dir * a.y,
                self.base.d1(a.x),
                self.dir,
            )
        })?;
        Some(DVec2::new(
            self.u_of(nat.x),
            (nat.y - self.phi.0) / (self.phi.1 - self.phi.0),
        ))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let th = lerp(self.theta.0, self.theta.1, uv.x);
                (self.theta.1 - self.theta.0) * (self.phi.1 - self.phi.0) * self.density(th)
            }
        }
    }
    fn area(&self) -> f64 {
        self.table.total() * (self.phi.1 - self.phi.0)
    }
    fn bounds(&self) -> Aabb {
        let b = self.base.bounds(self.theta.0, self.theta.1);
        let e0 = self.dir * self.phi.0;
        let e1 = self.dir * self.phi.1;
        let local = Aabb {
            min: b.min + e0.min(e1),
            max: b.max + e0.max(e1),
        };
        self.frame.box_to_world(local)
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::GeneralizedCylinder(self)
    }
}

/// A tangent developable `x(θ, φ) = y(θ) + φ y'(θ)` (VirtualMesh Appendix A.2), base
/// curve y over θ ∈ `theta`, `0 ≤ φ0 < φ1` (φ = 0 is the edge of regression).
/// Equal-area: u = K(θ)/K(θ1) with density `|y' × y''|`, v linear in φ²; Jacobian
/// `K(θ1)·(φ1² − φ0²)/2`. The base curve must have no inflection on the range.
#[derive(Debug, Clone)]
pub struct TangentDevelopable {
    frame: Frame,
    base: Arc<dyn Curve>,
    theta: (f64, f64),
    phi: (f64, f64),
    table: Arc<Cumulative>,
    kind: ParamKind,
}

impl TangentDevelopable {
    /// A tangent developable patch.
    ///
    /// # Errors
    /// Empty ranges, `φ0 < 0`, non-finite values, or a base curve with vanishing
    /// curvature (an inflection or straight piece) on the range.
    pub fn new(
        frame: Frame,
        base: Arc<dyn Curve>,
        theta: (f64, f64),
        phi: (f64, f64),
    ) -> Result<Self, ParamError> {
        let theta = range("base curve parameter range", theta)?;
        let phi = range("tangent length range", phi)?;
        if phi.0 < 0.0 {
            return Err(ParamError::InvalidRange {
                what: "tangent length range",
                lo: phi.0,
                hi: phi.1,
                why: "one sheet: need φ0 >= 0",
            });
        }
        let rho = |x: f64| base.d1(x).cross(base.d2(x)).length();
        check_density(theta, "base curve has zero curvature", rho)?;
        for i in 0..=64 {
            if rho(lerp(theta.0, theta.1, i as f64 / 64.0)) == 0.0 {
                return Err(ParamError::Degenerate("base curve has zero curvature"));
            }
        }
        let table = Arc::new(Cumulative::new(theta.0, theta.1, PANELS, ORDER, rho));
        Ok(Self {
            frame,
            base,
            theta,
            phi,
            table,
            kind: ParamKind::EqualArea,
        })
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map.",
        "The same patch with the natural map `(θ, φ)`."
    );
    /// Placement.
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Base curve (local coordinates).
    pub fn base(&self) -> &Arc<dyn Curve> {
        &self.base
    }
    /// Base-curve parameter range.
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Tangent-length range.
    pub fn phi_range(&self) -> (f64, f64) {
        self.phi
    }
    fn density(&self, t: f64) -> f64 {
        self.base.d1(t).cross(self.base.d2(t)).length()
    }
    fn phi_of(&self, v: f64) -> (f64, f64) {
        let (p0, p1) = self.phi;
        match self.kind {
            ParamKind::Natural => (lerp(p0, p1, v), p1 - p0),
            ParamKind::EqualArea => {
                let phi = lerp(p0 * p0, p1 * p1, v).max(0.0).sqrt();
                (phi, (p1 * p1 - p0 * p0) / (2.0 * phi))
            }
        }
    }
}

impl Parametrization for TangentDevelopable {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let (th, dth) = theta_of(self.kind, &self.table, self.theta, uv.x, |x| {
            self.density(x)
        });
        let (phi, dphi) = self.phi_of(uv.y);
        let y = self.base.point(th);
        let d1 = self.base.d1(th);
        let d2 = self.base.d2(th);
        let f = &self.frame;
        SurfacePoint {
            position: f.point_to_world(y + d1 * phi),
            normal: f.vector_to_world(d2.cross(d1).normalize()),
            dp_du: f.vector_to_world((d1 + d2 * phi) * dth),
            dp_dv: f.vector_to_world(d1 * dphi),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        let lo = DVec2::new(self.theta.0, self.phi.0);
        let hi = DVec2::new(self.theta.1, self.phi.1);
        let b = self.base.as_ref();
        let nat = closest_point(lo, hi, 16, q, |a| {
            let (d1, d2) = (b.d1(a.x), b.d2(a.x));
            (b.point(a.x) + d1 * a.y, d1 + d2 * a.y, d1)
        })?;
        let (p0, p1) = self.phi;
        let v = match self.kind {
            ParamKind::Natural => (nat.y - p0) / (p1 - p0),
            ParamKind::EqualArea => (nat.y * nat.y.abs() - p0 * p0) / (p1 * p1 - p0 * p0),
        };
        Some(DVec2::new(
            u_of(self.kind, &self.table, self.theta, nat.x, |x| {
                self.density(x)
            }),
            v,
        ))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let th = lerp(self.theta.0, self.theta.1, uv.x);
                let phi = lerp(self.phi.0, self.phi.1, uv.y);
                (self.theta.1 - self.theta.0) * (self.phi.1 - self.phi.0) * phi * self.density(th)
            }
        }
    }
    fn area(&self) -> f64 {
        let (p0, p1) = self.phi;
        self.table.total() * (p1 - p0) * (p1 + p0) * 0.5
    }
    fn bounds(&self) -> Aabb {
        let b = self.base.bounds(self.theta.0, self.theta.1);
        let d = self.base.derivative_bounds(self.theta.0, self.theta.1);
        let ph = Interval::new(self.phi.0, self.phi.1);
        let comp = |i: usize| Interval::new(d.min[i], d.max[i]).mul(ph);
        let (x, y, z) = (comp(0), comp(1), comp(2));
        let local = Aabb {
            min: b.min + DVec3::new(x.lo, y.lo, z.lo),
            max: b.max + DVec3::new(x.hi, y.hi, z.hi),
        };
        self.frame.box_to_world(local)
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::TangentDevelopable(self)
    }
}
