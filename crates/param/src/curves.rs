//! Curves used as profiles of surfaces of revolution and as base curves of generalized
//! cylinders and tangent developables (VirtualMesh Appendix A.2): Bézier curves of any
//! degree, the cardioid of the appendix's examples, and circular helices.

use crate::error::{ParamError, finite3, positive};
use crate::frame::Aabb;
use glam::DVec3;
use std::f64::consts::TAU;

/// A twice-differentiable space curve `t ↦ y(t)` with conservative bounds.
pub trait Curve: Send + Sync + std::fmt::Debug {
    /// Point y(t).
    fn point(&self, t: f64) -> DVec3;
    /// First derivative y'(t).
    fn d1(&self, t: f64) -> DVec3;
    /// Second derivative y''(t).
    fn d2(&self, t: f64) -> DVec3;
    /// A box containing y(t) for t ∈ [t0, t1].
    fn bounds(&self, t0: f64, t1: f64) -> Aabb;
    /// A box containing y'(t) for t ∈ [t0, t1].
    fn derivative_bounds(&self, t0: f64, t1: f64) -> Aabb;
}

/// A Bézier curve of degree `n ≥ 1` on t ∈ [0, 1] (de Casteljau evaluation).
#[derive(Debug, Clone, PartialEq)]
pub struct BezierCurve {
    ctrl: Vec<DVec3>,
    d1: Vec<DVec3>,
    d2: Vec<DVec3>,
}

/// de Casteljau evaluation of the Bézier polynomial with control points `c`.
pub(crate) fn de_casteljau(c: &[DVec3], t: f64) -> DVec3 {
    match c.len() {
        0 => DVec3::ZERO,
        1 => c[0],
        n => {
            let mut tmp: [DVec3; 8] = [DVec3::ZERO; 8];
            if n <= 8 {
                tmp[..n].copy_from_slice(c);
                for k in (1..n).rev() {
                    for i in 0..k {
                        tmp[i] = tmp[i].lerp(tmp[i + 1], t);
                    }
                }
                tmp[0]
            } else {
                let mut v = c.to_vec();
                for k in (1..n).rev() {
                    for i in 0..k {
                        v[i] = v[i].lerp(v[i + 1], t);
                    }
                }
                v[0]
            }
        }
    }
}

/// Control points of the derivative (hodograph).
pub(crate) fn hodograph(c: &[DVec3]) -> Vec<DVec3> {
    let n = c.len().saturating_sub(1) as f64;
    c.windows(2).map(|w| (w[1] - w[0]) * n).collect()
}

impl BezierCurve {
    /// A Bézier curve through its control points (at least 2).
    ///
    /// # Errors
    /// Fewer than 2 points or non-finite coordinates.
    pub fn new(control_points: Vec<DVec3>) -> Result<Self, ParamError> {
        if control_points.len() < 2 {
            return Err(ParamError::TooFewPoints {
                needed: 2,
                got: control_points.len(),
            });
        }
        for p in &control_points {
            finite3("Bézier control point", *p)?;
        }
        let d1 = hodograph(&control_points);
        let d2 = hodograph(&d1);
        Ok(Self {
            ctrl: control_points,
            d1,
            d2,
        })
    }
    /// Control points.
    pub fn control_points(&self) -> &[DVec3] {
        &self.ctrl
    }
}

impl Curve for BezierCurve {
    fn point(&self, t: f64) -> DVec3 {
        de_casteljau(&self.ctrl, t)
    }
    fn d1(&self, t: f64) -> DVec3 {
        de_casteljau(&self.d1, t)
    }
    fn d2(&self, t: f64) -> DVec3 {
        de_casteljau(&self.d2, t)
    }
    fn bounds(&self, _t0: f64, _t1: f64) -> Aabb {
        // Convex-hull property (for t in [0, 1]).
        Aabb::from_points(self.ctrl.iter().copied())
    }
    fn derivative_bounds(&self, _t0: f64, _t1: f64) -> Aabb {
        Aabb::from_points(self.d1.iter().copied())
    }
}

/// The cardioid `y(θ) = (a cos θ (1 + cos θ), a sin θ (1 + cos θ), 0)` of VirtualMesh
/// Appendix A.2; θ ∈ [0, 2π), cusp at θ = π.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cardioid {
    a: f64,
}

impl Cardioid {
    /// A cardioid of size `a`.
    ///
    /// # Errors
    /// Non-positive or non-finite `a`.
    pub fn new(a: f64) -> Result<Self, ParamError> {
        Ok(Self {
            a: positive("cardioid size", a)?,
        })
    }
    /// Size parameter a.
    pub fn size(&self) -> f64 {
        self.a
    }
}

impl Curve for Cardioid {
    fn point(&self, t: f64) -> DVec3 {
        let (s, c) = t.sin_cos();
        DVec3::new(c * (1.0 + c), s * (1.0 + c), 0.0) * self.a
    }
    fn d1(&self, t: f64) -> DVec3 {
        let (s, c) = t.sin_cos();
        // d/dθ [cos θ + cos² θ] = −sin θ − sin 2θ; d/dθ [sin θ + sin θ cos θ] = cos θ + cos 2θ.
        DVec3::new(-s - 2.0 * s * c, c + (c * c - s * s), 0.0) * self.a
    }
    fn d2(&self, t: f64) -> DVec3 {
        let (s, c) = t.sin_cos();
        DVec3::new(-c - 2.0 * (c * c - s * s), -s - 4.0 * s * c, 0.0) * self.a
    }
    fn bounds(&self, _t0: f64, _t1: f64) -> Aabb {
        // x = cos θ + cos² θ ∈ [−1/4, 2]; |y| = |sin θ (1 + cos θ)| ≤ 3√3/4.
        let ym = 0.75 * 3f64.sqrt() * self.a;
        Aabb {
            min: DVec3::new(-0.25 * self.a, -ym, 0.0),
            max: DVec3::new(2.0 * self.a, ym, 0.0),
        }
    }
    fn derivative_bounds(&self, _t0: f64, _t1: f64) -> Aabb {
        // |y'| = 2a |cos(θ/2)| ≤ 2a.
        Aabb {
            min: DVec3::new(-2.0 * self.a, -2.0 * self.a, 0.0),
            max: DVec3::new(2.0 * self.a, 2.0 * self.a, 0.0),
        }
    }
}

/// A circular helix `(r cos t, r sin t, h t / 2π)` (pitch h per turn).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Helix {
    radius: f64,
    pitch: f64,
}

impl Helix {
    /// A helix of radius `radius` rising `pitch` per turn.
    ///
    /// # Errors
    /// Non-positive radius or non-finite pitch.
    pub fn new(radius: f64, pitch: f64) -> Result<Self, ParamError> {
        crate::error::finite("helix pitch", pitch)?;
        Ok(Self {
            radius: positive("helix radius", radius)?,
            pitch,
        })
    }
}

impl Curve for Helix {
    fn point(&self, t: f64) -> DVec3 {
        let (s, c) = t.sin_cos();
        DVec3::new(self.radius * c, self.radius * s, self.pitch * t / TAU)
    }
    fn d1(&self, t: f64) -> DVec3 {
        let (s, c) = t.sin_cos();
        DVec3::new(-self.radius * s, self.radius * c, self.pitch / TAU)
    }
    fn d2(&self, t: f64) -> DVec3 {
        let (s, c) = t.sin_cos();
        DVec3::new(-self.radius * c, -self.radius * s, 0.0)
    }
    fn bounds(&self, t0: f64, t1: f64) -> Aabb {
        let r = self.radius;
        let (z0, z1) = (self.pitch * t0 / TAU, self.pitch * t1 / TAU);
        Aabb {
            min: DVec3::new(-r, -r, z0.min(z1)),
            max: DVec3::new(r, r, z0.max(z1)),
        }
    }
    fn derivative_bounds(&self, _t0: f64, _t1: f64) -> Aabb {
        let r = self.radius;
        let z = self.pitch / TAU;
        Aabb {
            min: DVec3::new(-r, -r, z),
            max: DVec3::new(r, r, z),
        }
    }
}
