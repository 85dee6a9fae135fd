//! Direction maps between the unit square and the hemisphere or sphere of directions,
//! with their solid-angle Jacobians (sr per unit parameter area), for glossy radiance
//! (Glossy §3.3) and volumes.
//!
//! * [`GlossyHemisphere`] — Glossy §3.3: "gnomonic" projection of the hemisphere to the
//!   disc of radius π/2 (the paper's description — great circles through the pole map
//!   to radial lines with arc length preserved — is the azimuthal equidistant
//!   projection, which we implement), then a radial stretch of the disc onto the square
//!   (derivative discontinuity on the diagonals). Not equal-area.
//! * [`ConcentricHemisphere`] — Shirley and Chiu's concentric square-to-disc map
//!   followed by the equal-area lift `z = 1 − r²`; Jacobian 2π.
//! * [`OctahedralSphere`] — equal-area octahedral map of the whole sphere (upper
//!   hemisphere = inner diamond, lower = folded corners; Clarberg 2008); Jacobian 4π.
//!
//! Directions are unit vectors in a local frame with the pole (surface normal) on +z.

use glam::{DVec2, DVec3};
use std::f64::consts::{FRAC_PI_2, FRAC_PI_4, PI, TAU};

/// A map from the unit square onto a set of directions.
pub trait DirectionMap: Send + Sync + std::fmt::Debug {
    /// Unit direction at `uv` ∈ [0, 1]².
    fn direction(&self, uv: DVec2) -> DVec3;
    /// Parameters of a direction (normalised internally); `None` for a zero or
    /// non-finite vector or one outside the covered set (e.g. z < 0 for a hemisphere).
    fn inverse(&self, d: DVec3) -> Option<DVec2>;
    /// Solid angle per unit parameter area at `uv` (sr).
    fn jacobian(&self, uv: DVec2) -> f64;
    /// Total solid angle covered (sr).
    fn solid_angle(&self) -> f64;
    /// Whether the Jacobian is constant.
    fn is_equal_area(&self) -> bool;
}

/// Glossy §3.3 hemisphere ↔ square map (equidistant projection + radial stretch).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GlossyHemisphere;

impl DirectionMap for GlossyHemisphere {
    fn direction(&self, uv: DVec2) -> DVec3 {
        let q = uv * 2.0 - 1.0;
        let rho = q.x.abs().max(q.y.abs());
        let len = q.length();
        if len == 0.0 {
            return DVec3::Z;
        }
        let (st, ct) = (rho * FRAC_PI_2).sin_cos();
        DVec3::new(st * q.x / len, st * q.y / len, ct)
    }
    fn inverse(&self, d: DVec3) -> Option<DVec2> {
        let d = d.try_normalize()?;
        if d.z < 0.0 {
            return None;
        }
        let s = d.x.hypot(d.y);
        if s == 0.0 {
            return Some(DVec2::splat(0.5));
        }
        let theta = s.atan2(d.z);
        let rho = theta / FRAC_PI_2;
        let c = DVec2::new(d.x, d.y) / s;
        let q = c * (rho / c.x.abs().max(c.y.abs()));
        Some((q + 1.0) * 0.5)
    }
    fn jacobian(&self, uv: DVec2) -> f64 {
        let q = uv * 2.0 - 1.0;
        let rho = q.x.abs().max(q.y.abs());
        let m = q.x.abs().min(q.y.abs());
        // sin(πρ/2)·ρ/|q|² = sin(πρ/2)/ρ · 1/(1 + (m/ρ)²), finite at the centre.
        let ratio = if rho == 0.0 { 0.0 } else { m / rho };
        let sinc = if rho == 0.0 {
            FRAC_PI_2
        } else {
            (rho * FRAC_PI_2).sin() / rho
        };
        TAU * sinc / (1.0 + ratio * ratio)
    }
    fn solid_angle(&self) -> f64 {
        TAU
    }
    fn is_equal_area(&self) -> bool {
        false
    }
}

/// Shirley–Chiu concentric map from [−1, 1]² to the unit disc.
pub fn concentric_square_to_disc(q: DVec2) -> DVec2 {
    let (a, b) = (q.x, q.y);
    if a == 0.0 && b == 0.0 {
        return DVec2::ZERO;
    }
    let (r, phi) = if a.abs() > b.abs() {
        (a, FRAC_PI_4 * (b / a))
    } else {
        (b, FRAC_PI_2 - FRAC_PI_4 * (a / b))
    };
    DVec2::new(r * phi.cos(), r * phi.sin())
}

/// Inverse of [`concentric_square_to_disc`].
pub fn concentric_disc_to_square(p: DVec2) -> DVec2 {
    let r = p.length();
    if r == 0.0 {
        return DVec2::ZERO;
    }
    let mut phi = p.y.atan2(p.x);
    if phi < -FRAC_PI_4 {
        phi += TAU;
    }
    if phi < FRAC_PI_4 {
        DVec2::new(r, phi / FRAC_PI_4 * r)
    } else if phi < 3.0 * FRAC_PI_4 {
        DVec2::new(-(phi - FRAC_PI_2) / FRAC_PI_4 * r, r)
    } else if phi < 5.0 * FRAC_PI_4 {
        DVec2::new(-r, -(phi - PI) / FRAC_PI_4 * r)
    } else {
        DVec2::new((phi - 3.0 * FRAC_PI_2) / FRAC_PI_4 * r, -r)
    }
}

/// Shirley–Chiu concentric equal-area hemisphere map.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ConcentricHemisphere;

impl DirectionMap for ConcentricHemisphere {
    fn direction(&self, uv: DVec2) -> DVec3 {
        let p = concentric_square_to_disc(uv * 2.0 - 1.0);
        let r2 = p.length_squared().min(1.0);
        let s = (2.0 - r2).sqrt();
        DVec3::new(p.x * s, p.y * s, 1.0 - r2)
    }
    fn inverse(&self, d: DVec3) -> Option<DVec2> {
        let d = d.try_normalize()?;
        if d.z < 0.0 {
            return None;
        }
        let s2 = d.x * d.x + d.y * d.y;
        let s = s2.sqrt();
        if s == 0.0 {
            return Some(DVec2::splat(0.5));
        }
        // r² = 1 − z = s²/(1 + z) without cancellation.
        let r = (s2 / (1.0 + d.z)).sqrt();
        let p = DVec2::new(d.x, d.y) * (r / s);
        Some((concentric_disc_to_square(p) + 1.0) * 0.5)
    }
    fn jacobian(&self, _uv: DVec2) -> f64 {
        TAU
    }
    fn solid_angle(&self) -> f64 {
        TAU
    }
    fn is_equal_area(&self) -> bool {
        true
    }
}

/// Equal-area octahedral map of the whole sphere of directions. Seams: the square's
/// boundary (edges are identified pairwise by the fold) and its diagonals' ends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct OctahedralSphere;

impl DirectionMap for OctahedralSphere {
    fn direction(&self, uv: DVec2) -> DVec3 {
        let q = uv * 2.0 - 1.0;
        let (a, b) = (q.x.abs(), q.y.abs());
        let sd = 1.0 - (a + b);
        let r = 1.0 - sd.abs();
        let phi = if r == 0.0 {
            FRAC_PI_4
        } else {
            ((b - a) / r + 1.0) * FRAC_PI_4
        };
        let z = (1.0 - r * r).copysign(sd);
        let s = r * (2.0 - r * r).max(0.0).sqrt();
        let (sp, cp) = phi.sin_cos();
        DVec3::new((cp * s).copysign(q.x), (sp * s).copysign(q.y), z)
    }
    fn inverse(&self, d: DVec3) -> Option<DVec2> {
        let d = d.try_normalize()?;
        let s2 = d.x * d.x + d.y * d.y;
        let r = (s2 / (1.0 + d.z.abs())).sqrt();
        let phi = d.y.abs().atan2(d.x.abs());
        let w = (phi / FRAC_PI_4 - 1.0) * r;
        let sum = if d.z >= 0.0 { r } else { 2.0 - r };
        let a = (0.5 * (sum - w)).max(0.0);
        let b = (0.5 * (sum + w)).max(0.0);
        let q = DVec2::new(a.copysign(d.x), b.copysign(d.y));
        Some((q + 1.0) * 0.5)
    }
    fn jacobian(&self, _uv: DVec2) -> f64 {
        4.0 * PI
    }
    fn solid_angle(&self) -> f64 {
        4.0 * PI
    }
    fn is_equal_area(&self) -> bool {
        true
    }
}
