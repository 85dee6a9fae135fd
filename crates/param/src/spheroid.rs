//! Spheroid patches (VirtualMesh Appendix A.1): prolate (b > a) and oblate (b < a)
//! ellipsoids of revolution `x²/a² + y²/a² + z²/b² = 1`, natural parameters
//! `(a cos φ cos θ, a cos φ sin θ, b sin φ)` (φ = parametric latitude).
//!
//! The equal-area coordinate is the cumulative area
//! `G(w) = ∫₀^w √(b²(1 − x²) + a² x²) dx`, `w = sin φ`, in closed form
//! `G(w) = ½ (w q(w) + b w F(z))` with `q(w) = √(b²(1−w²) + a²w²)`,
//! `z = w √|a² − b²| / b` and `F(z) = asin(z)/z` (prolate) or `asinh(z)/z` (oblate);
//! for the prolate case this is the appendix's
//! `b/2 (w √(1 − e² w²) + asin(e w)/e)`. `F` switches to its Taylor series for small
//! `z`, so the map is stable as e → 0 (where it becomes the sphere's `(θ, sin φ)`), and
//! every square root is formed without cancellation, so it stays accurate as e → 1.
//! G is inverted by safeguarded Newton (G' = q > 0). Jacobian `a·Δθ·(G(w1) − G(w0))`.

use crate::error::{ParamError, angle_range, finite, positive};
use crate::frame::{
    Aabb, Frame, SurfacePoint, cos_from_sin, cos_range, revolution_box, sin_range, unwrap_angle,
};
use crate::numeric::solve_increasing;
use crate::quadrics::latitude_range;
use crate::surface::{ParamKind, Parametrization, SurfaceShape, lerp};
use glam::{DVec2, DVec3};

/// A spheroid patch over azimuth `theta` and parametric latitude `latitude`.
#[derive(Debug, Clone, PartialEq)]
pub struct Spheroid {
    frame: Frame,
    a: f64,
    b: f64,
    /// √|a² − b²| / b.
    zeta: f64,
    prolate: bool,
    theta: (f64, f64),
    lat: (f64, f64),
    w0: f64,
    w1: f64,
    g0: f64,
    g1: f64,
    kind: ParamKind,
}

/// `asin(z)/z` (prolate) or `asinh(z)/z` (oblate), series near 0.
fn f_ratio(z: f64, prolate: bool) -> f64 {
    let z2 = z * z;
    if z.abs() < 1e-3 {
        let s = if prolate { 1.0 } else { -1.0 };
        1.0 + s * z2 / 6.0 + 3.0 * z2 * z2 / 40.0 + s * 5.0 * z2 * z2 * z2 / 112.0
    } else if prolate {
        z.asin() / z
    } else {
        z.asinh() / z
    }
}

impl Spheroid {
    /// A spheroid patch with equatorial semi-axis `a` and polar semi-axis `b`.
    ///
    /// # Errors
    /// Non-positive semi-axes, latitude range outside [−π/2, π/2], bad azimuth range.
    pub fn new(
        frame: Frame,
        equatorial: f64,
        polar: f64,
        theta: (f64, f64),
        latitude: (f64, f64),
    ) -> Result<Self, ParamError> {
        let a = positive("spheroid equatorial semi-axis", equatorial)?;
        let b = positive("spheroid polar semi-axis", polar)?;
        let theta = angle_range("spheroid azimuth", theta)?;
        let lat = latitude_range("spheroid latitude", latitude)?;
        let prolate = b >= a;
        let zeta = ((a - b).abs() * (a + b)).sqrt() / b;
        let mut s = Self {
            frame,
            a,
            b,
            zeta,
            prolate,
            theta,
            lat,
            w0: lat.0.sin(),
            w1: lat.1.sin(),
            g0: 0.0,
            g1: 0.0,
            kind: ParamKind::EqualArea,
        };
        s.g0 = s.g(s.w0);
        s.g1 = s.g(s.w1);
        Ok(s)
    }

    /// A prolate spheroid with polar semi-axis `polar` and eccentricity
    /// `e = √(1 − a²/b²)` (so `a = b √(1 − e²)`).
    ///
    /// # Errors
    /// [`ParamError::Eccentricity`] unless `0 ≤ e < 1`; otherwise as [`Spheroid::new`].
    pub fn prolate(
        frame: Frame,
        polar: f64,
        e: f64,
        theta: (f64, f64),
        latitude: (f64, f64),
    ) -> Result<Self, ParamError> {
        let e = check_e(e)?;
        let b = positive("spheroid polar semi-axis", polar)?;
        Self::new(
            frame,
            b * ((1.0 - e) * (1.0 + e)).sqrt(),
            b,
            theta,
            latitude,
        )
    }

    /// An oblate spheroid with equatorial semi-axis `equatorial` and eccentricity
    /// `e = √(1 − b²/a²)` (so `b = a √(1 − e²)`).
    ///
    /// # Errors
    /// [`ParamError::Eccentricity`] unless `0 ≤ e < 1`; otherwise as [`Spheroid::new`].
    pub fn oblate(
        frame: Frame,
        equatorial: f64,
        e: f64,
        theta: (f64, f64),
        latitude: (f64, f64),
    ) -> Result<Self, ParamError> {
        let e = check_e(e)?;
        let a = positive("spheroid equatorial semi-axis", equatorial)?;
        Self::new(
            frame,
            a,
            a * ((1.0 - e) * (1.0 + e)).sqrt(),
            theta,
            latitude,
        )
    }

    crate::map_kind_switch!(
        "The same patch with the equal-area map `(θ, G(sin φ))`.",
        "The same patch with the natural map `(θ, φ)`."
    );
    /// Placement (centre = origin, polar axis = local z).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Centre (world).
    pub fn centre(&self) -> DVec3 {
        self.frame.origin()
    }
    /// Equatorial semi-axis a.
    pub fn equatorial_semi_axis(&self) -> f64 {
        self.a
    }
    /// Polar semi-axis b.
    pub fn polar_semi_axis(&self) -> f64 {
        self.b
    }
    /// Whether b ≥ a.
    pub fn is_prolate(&self) -> bool {
        self.prolate
    }
    /// Eccentricity `√|a² − b²| / max(a, b)`.
    pub fn eccentricity(&self) -> f64 {
        ((self.a - self.b).abs() * (self.a + self.b)).sqrt() / self.a.max(self.b)
    }
    /// Azimuth range (radians).
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Parametric-latitude range (radians).
    pub fn latitude_range(&self) -> (f64, f64) {
        self.lat
    }

    /// `q(w) = √(b²(1 − w²) + a² w²)`.
    #[inline]
    fn q(&self, w: f64) -> f64 {
        let c2 = (1.0 - w) * (1.0 + w);
        (self.b * self.b * c2 + self.a * self.a * w * w).sqrt()
    }

    /// Cumulative area coordinate `G(w)`.
    fn g(&self, w: f64) -> f64 {
        0.5 * (w * self.q(w) + self.b * w * f_ratio(self.zeta * w, self.prolate))
    }

    /// (w, dw/dt) for the second unit-square coordinate.
    fn w_of(&self, t: f64) -> (f64, f64) {
        match self.kind {
            ParamKind::Natural => {
                let phi = lerp(self.lat.0, self.lat.1, t);
                (phi.sin(), f64::NAN)
            }
            ParamKind::EqualArea => {
                let target = lerp(self.g0, self.g1, t);
                let guess = lerp(self.w0, self.w1, t);
                let w = solve_increasing(-1.0, 1.0, target, guess, |w| (self.g(w), self.q(w)));
                (w, (self.g1 - self.g0) / self.q(w))
            }
        }
    }
}

fn check_e(e: f64) -> Result<f64, ParamError> {
    finite("eccentricity", e)?;
    if (0.0..1.0).contains(&e) {
        Ok(e)
    } else {
        Err(ParamError::Eccentricity(e))
    }
}

impl Parametrization for Spheroid {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let th = lerp(self.theta.0, self.theta.1, uv.x);
        let (st, ct) = th.sin_cos();
        let (a, b) = (self.a, self.b);
        let (w, c, dlat) = match self.kind {
            ParamKind::Natural => {
                let phi = lerp(self.lat.0, self.lat.1, uv.y);
                let (w, c) = phi.sin_cos();
                let d = self.lat.1 - self.lat.0;
                (w, c, DVec3::new(-a * w * ct, -a * w * st, b * c) * d)
            }
            ParamKind::EqualArea => {
                let (w, dw) = self.w_of(uv.y);
                let c = cos_from_sin(w);
                (w, c, DVec3::new(-a * w / c * ct, -a * w / c * st, b) * dw)
            }
        };
        let f = &self.frame;
        SurfacePoint {
            position: f.point_to_world(DVec3::new(a * c * ct, a * c * st, b * w)),
            normal: f.vector_to_world(DVec3::new(b * c * ct, b * c * st, a * w).normalize()),
            dp_du: f.vector_to_world(
                DVec3::new(-st, ct, 0.0) * (a * c * (self.theta.1 - self.theta.0)),
            ),
            dp_dv: f.vector_to_world(dlat),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        if !q.is_finite() || q == DVec3::ZERO {
            return None;
        }
        let th = if q.x == 0.0 && q.y == 0.0 {
            0.5 * (self.theta.0 + self.theta.1)
        } else {
            unwrap_angle(q.y.atan2(q.x), self.theta.0, self.theta.1)
        };
        let u = (th - self.theta.0) / (self.theta.1 - self.theta.0);
        let (sz, sr) = (q.z / self.b, q.x.hypot(q.y) / self.a);
        let v = match self.kind {
            ParamKind::Natural => (sz.atan2(sr) - self.lat.0) / (self.lat.1 - self.lat.0),
            ParamKind::EqualArea => {
                let w = sz / sz.hypot(sr);
                (self.g(w) - self.g0) / (self.g1 - self.g0)
            }
        };
        Some(DVec2::new(u, v))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let phi = lerp(self.lat.0, self.lat.1, uv.y);
                let (w, c) = phi.sin_cos();
                self.a * c * self.q(w) * (self.theta.1 - self.theta.0) * (self.lat.1 - self.lat.0)
            }
        }
    }
    fn area(&self) -> f64 {
        self.a * (self.theta.1 - self.theta.0) * (self.g1 - self.g0)
    }
    fn bounds(&self) -> Aabb {
        let rho = cos_range(self.lat.0, self.lat.1).scale(self.a);
        let z = sin_range(self.lat.0, self.lat.1).scale(self.b);
        self.frame.box_to_world(revolution_box(self.theta, rho, z))
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Spheroid(self)
    }
}
