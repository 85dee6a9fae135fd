//! Ring-torus patches (VirtualMesh §3.1.3, Fig. 4) with general radii `0 < r < R`.
//!
//! Natural parameters: local `((R + r cos φ) cos θ, (R + r cos φ) sin θ, r sin φ)`.
//! Equal-area map (eq. (2) with f linear): u linear in θ and v linear in
//! `H(φ) = R φ + r sin φ` (the paper's `v = φ + ½ sin φ` for R = 2, r = 1); H is
//! inverted numerically by safeguarded Newton (H' = R + r cos φ ≥ R − r > 0).
//! Jacobian `r·Δθ·(H(φ1) − H(φ0))`.

use crate::error::{ParamError, angle_range, positive};
use crate::frame::{
    Aabb, Frame, Interval, SurfacePoint, cos_range, revolution_box, sin_range, unwrap_angle,
};
use crate::numeric::solve_increasing;
use crate::surface::{ParamKind, Parametrization, SurfaceShape, lerp};
use glam::{DVec2, DVec3};

/// A ring-torus patch θ ∈ `theta`, φ ∈ `phi` (both at most 2π long) around the
/// frame's z axis; φ = 0 is the outer equator, the normal points out of the tube.
#[derive(Debug, Clone, PartialEq)]
pub struct Torus {
    frame: Frame,
    major: f64,
    minor: f64,
    k: f64,
    theta: (f64, f64),
    phi: (f64, f64),
    /// Normalised H(φ)/R at the ends of the φ range.
    h0: f64,
    h1: f64,
    kind: ParamKind,
}

impl Torus {
    /// A ring-torus patch with major radius `major` (R) and tube radius `minor` (r).
    ///
    /// # Errors
    /// Non-positive or non-finite radii, `minor >= major` ([`ParamError::NotRingTorus`]),
    /// empty ranges or ranges longer than 2π.
    pub fn new(
        frame: Frame,
        major: f64,
        minor: f64,
        theta: (f64, f64),
        phi: (f64, f64),
    ) -> Result<Self, ParamError> {
        let major = positive("torus major radius", major)?;
        let minor = positive("torus minor radius", minor)?;
        if minor >= major {
            return Err(ParamError::NotRingTorus { minor, major });
        }
        let theta = angle_range("torus azimuth θ", theta)?;
        let phi = angle_range("torus tube angle φ", phi)?;
        let k = minor / major;
        Ok(Self {
            frame,
            major,
            minor,
            k,
            theta,
            phi,
            h0: phi.0 + k * phi.0.sin(),
            h1: phi.1 + k * phi.1.sin(),
            kind: ParamKind::EqualArea,
        })
    }
    crate::map_kind_switch!(
        "The same patch with the equal-area map `(θ, Rφ + r sin φ)`.",
        "The same patch with the natural map `(θ, φ)`."
    );
    /// Placement (centre = origin, axis = local z).
    pub fn frame(&self) -> &Frame {
        &self.frame
    }
    /// Centre (world).
    pub fn centre(&self) -> DVec3 {
        self.frame.origin()
    }
    /// Major radius R (centre to tube centre).
    pub fn major_radius(&self) -> f64 {
        self.major
    }
    /// Minor (tube) radius r.
    pub fn minor_radius(&self) -> f64 {
        self.minor
    }
    /// Azimuth range θ (radians).
    pub fn theta_range(&self) -> (f64, f64) {
        self.theta
    }
    /// Tube-angle range φ (radians).
    pub fn phi_range(&self) -> (f64, f64) {
        self.phi
    }

    /// Normalised `H(φ)/R = φ + k sin φ`.
    #[inline]
    fn h(&self, phi: f64) -> f64 {
        phi + self.k * phi.sin()
    }

    /// Natural parameters (θ, φ) of unit-square coordinates.
    pub fn natural_parameters(&self, uv: DVec2) -> DVec2 {
        DVec2::new(lerp(self.theta.0, self.theta.1, uv.x), self.phi_of(uv.y).0)
    }

    /// Unit-square coordinates of natural parameters (θ, φ) (no wrapping).
    pub fn unit_coordinates(&self, natural: DVec2) -> DVec2 {
        let u = (natural.x - self.theta.0) / (self.theta.1 - self.theta.0);
        let v = match self.kind {
            ParamKind::Natural => (natural.y - self.phi.0) / (self.phi.1 - self.phi.0),
            ParamKind::EqualArea => (self.h(natural.y) - self.h0) / (self.h1 - self.h0),
        };
        DVec2::new(u, v)
    }

    /// φ and dφ/dt at the second unit-square coordinate `t`.
    fn phi_of(&self, t: f64) -> (f64, f64) {
        let (p0, p1) = self.phi;
        match self.kind {
            ParamKind::Natural => (lerp(p0, p1, t), p1 - p0),
            ParamKind::EqualArea => {
                let target = lerp(self.h0, self.h1, t);
                let span = p1 - p0;
                // H is increasing on all of R; bracket generously for t outside [0, 1].
                let (lo, hi) = if (0.0..=1.0).contains(&t) {
                    (p0, p1)
                } else {
                    let ext = span * (t.abs() + 1.0) + 2.0;
                    (p0 - ext, p1 + ext)
                };
                let phi = solve_increasing(lo, hi, target, lerp(p0, p1, t), |x| {
                    let (s, c) = x.sin_cos();
                    (x + self.k * s, 1.0 + self.k * c)
                });
                (phi, (self.h1 - self.h0) / (1.0 + self.k * phi.cos()))
            }
        }
    }
}

impl Parametrization for Torus {
    fn eval(&self, uv: DVec2) -> SurfacePoint {
        let th = lerp(self.theta.0, self.theta.1, uv.x);
        let (phi, dphi) = self.phi_of(uv.y);
        let (st, ct) = th.sin_cos();
        let (sp, cp) = phi.sin_cos();
        let rho = self.major + self.minor * cp;
        let f = &self.frame;
        SurfacePoint {
            position: f.point_to_world(DVec3::new(rho * ct, rho * st, self.minor * sp)),
            normal: f.vector_to_world(DVec3::new(cp * ct, cp * st, sp)),
            dp_du: f
                .vector_to_world(DVec3::new(-st, ct, 0.0) * (rho * (self.theta.1 - self.theta.0))),
            dp_dv: f.vector_to_world(DVec3::new(-sp * ct, -sp * st, cp) * (self.minor * dphi)),
        }
    }
    fn inverse(&self, p: DVec3) -> Option<DVec2> {
        let q = self.frame.point_to_local(p);
        if !q.is_finite() || (q.x == 0.0 && q.y == 0.0) {
            return None;
        }
        let rho = q.x.hypot(q.y);
        let dr = rho - self.major;
        if dr == 0.0 && q.z == 0.0 {
            return None;
        }
        let th = unwrap_angle(q.y.atan2(q.x), self.theta.0, self.theta.1);
        let phi = unwrap_angle(q.z.atan2(dr), self.phi.0, self.phi.1);
        Some(self.unit_coordinates(DVec2::new(th, phi)))
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        match self.kind {
            ParamKind::EqualArea => self.area(),
            ParamKind::Natural => {
                let phi = lerp(self.phi.0, self.phi.1, uv.y);
                self.minor
                    * (self.major + self.minor * phi.cos())
                    * (self.theta.1 - self.theta.0)
                    * (self.phi.1 - self.phi.0)
            }
        }
    }
    fn area(&self) -> f64 {
        self.minor * self.major * (self.theta.1 - self.theta.0) * (self.h1 - self.h0)
    }
    fn bounds(&self) -> Aabb {
        let rho = cos_range(self.phi.0, self.phi.1)
            .scale(self.minor)
            .add(Interval::new(self.major, self.major));
        let z = sin_range(self.phi.0, self.phi.1).scale(self.minor);
        self.frame.box_to_world(revolution_box(self.theta, rho, z))
    }
    fn kind(&self) -> ParamKind {
        self.kind
    }
    fn shape(&self) -> SurfaceShape<'_> {
        SurfaceShape::Torus(self)
    }
}
