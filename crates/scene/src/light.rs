//! Punctual lights: point and spot lights with the glTF `KHR_lights_punctual` cone
//! falloff, for the meshless direct-to-indirect relighting (Meshless §3.3: "a single
//! pointlike spotlight as the source of direct illumination") and the path tracer's
//! next-event estimation.
//!
//! # Units and conventions
//!
//! - `intensity` is the radiant intensity on the light's axis, W/sr per RGB channel. A
//!   glTF light's `color × intensity` (candela) is read as W/sr without photometric
//!   conversion (ours, like emission: one radiometric convention in every loader).
//! - The irradiance on a surface at distance `d` whose normal makes angle `θ` with the
//!   direction to the light is `I(ω)·cos θ / d²`; glTF's `range` is not applied
//!   (physical inverse-square falloff, ours).
//! - A spot radiates inside a cone about `direction` (unit) with the glTF falloff
//!   `f(μ) = clamp((μ − cos θ_o)/(cos θ_i − cos θ_o), 0, 1)²` of `μ = cos` of the angle
//!   to the axis (glTF's recommended implementation; `θ_i = θ_o` is a hard edge, ours,
//!   instead of glTF's `max(0.001, ·)` guard). `θ_o ∈ (0, π]` (wider than glTF's
//!   `π/2`, ours: `π` is an omnidirectional light) and `0 <= θ_i <= θ_o`.
//! - The emitted power is `Φ = 2π I ∫ f(μ) dμ = 2π I ((1 − cos θ_i) + (cos θ_i − cos θ_o)/3)`
//!   (exact for the quadratic falloff); a point light has `Φ = 4π I`.

use glam::DVec3;

use crate::error::SceneError;
use crate::material::Rgb;

/// What kind of punctual light.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum LightKind {
    /// Radiates `intensity` in every direction.
    Point,
    /// Radiates inside a cone about `direction` with the glTF falloff.
    Spot {
        /// Unit axis of the cone.
        direction: DVec3,
        /// Inner cone half-angle (radians), full intensity inside.
        inner: f64,
        /// Outer cone half-angle (radians), `(0, π]`, zero outside.
        outer: f64,
    },
}

/// A punctual light (see the module docs for units).
#[derive(Debug, Clone, PartialEq)]
pub struct Light {
    /// Name (glTF node name or native `name`).
    pub name: String,
    /// Position (scene units).
    pub position: DVec3,
    /// Radiant intensity on the axis, W/sr per RGB channel.
    pub intensity: Rgb,
    /// Point or spot.
    pub kind: LightKind,
}

impl Light {
    /// A point light.
    pub fn point(name: impl Into<String>, position: DVec3, intensity: Rgb) -> Self {
        Self {
            name: name.into(),
            position,
            intensity,
            kind: LightKind::Point,
        }
    }

    /// A spot light; `direction` is normalised here (a zero direction is caught by
    /// [`Light::validate`]).
    pub fn spot(
        name: impl Into<String>,
        position: DVec3,
        direction: DVec3,
        inner: f64,
        outer: f64,
        intensity: Rgb,
    ) -> Self {
        Self {
            name: name.into(),
            position,
            intensity,
            kind: LightKind::Spot {
                direction: direction.try_normalize().unwrap_or(DVec3::ZERO),
                inner,
                outer,
            },
        }
    }

    /// Checks the light: finite position, finite non-negative intensity, a unit spot
    /// direction and `0 <= inner <= outer`, `outer ∈ (0, π]`. `file` names the source.
    ///
    /// # Errors
    /// [`SceneError::NonFinite`] or [`SceneError::Malformed`] naming `light "name"`.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let element = format!("light {:?}", self.name);
        let nonfinite = |what: &str, value: f64| SceneError::NonFinite {
            file: file.into(),
            element: element.clone(),
            what: what.into(),
            value,
        };
        let malformed = |what: String| SceneError::Malformed {
            file: file.into(),
            element: element.clone(),
            what,
        };
        for c in self.position.to_array() {
            if !c.is_finite() {
                return Err(nonfinite("position", c));
            }
        }
        for c in self.intensity.0 {
            if !c.is_finite() {
                return Err(nonfinite("intensity", c));
            }
            if c < 0.0 {
                return Err(malformed(format!("negative intensity {c}")));
            }
        }
        if let LightKind::Spot {
            direction,
            inner,
            outer,
        } = self.kind
        {
            for c in direction.to_array() {
                if !c.is_finite() {
                    return Err(nonfinite("direction", c));
                }
            }
            if (direction.length() - 1.0).abs() > 1e-9 {
                return Err(malformed("zero spot direction".into()));
            }
            if !(outer > 0.0 && outer <= std::f64::consts::PI) {
                return Err(malformed(format!(
                    "outer cone angle {outer} rad outside (0, π]"
                )));
            }
            if !(inner >= 0.0 && inner <= outer) {
                return Err(malformed(format!(
                    "inner cone angle {inner} rad outside [0, outer = {outer}]"
                )));
            }
        }
        Ok(())
    }

    /// The angular falloff in `[0, 1]` towards the unit direction `dir` (1 for a point
    /// light; the glTF cone falloff of the module docs for a spot).
    pub fn falloff(&self, dir: DVec3) -> f64 {
        match self.kind {
            LightKind::Point => 1.0,
            LightKind::Spot {
                direction,
                inner,
                outer,
            } => {
                let mu = direction.dot(dir);
                let (ci, co) = (inner.cos(), outer.cos());
                if ci - co <= 0.0 {
                    return if mu >= co { 1.0 } else { 0.0 };
                }
                let t = ((mu - co) / (ci - co)).clamp(0.0, 1.0);
                t * t
            }
        }
    }

    /// Radiant intensity towards the unit direction `dir` (W/sr per channel).
    pub fn intensity_towards(&self, dir: DVec3) -> [f64; 3] {
        let f = self.falloff(dir);
        self.intensity.0.map(|c| c * f)
    }

    /// Unoccluded irradiance (W/m² per channel) at `x` on a surface with unit normal `n`
    /// (zero behind the surface or at the light's position).
    pub fn irradiance_at(&self, x: DVec3, n: DVec3) -> [f64; 3] {
        let d = self.position - x;
        let r2 = d.length_squared();
        if !(r2 > 0.0) || !r2.is_finite() {
            return [0.0; 3];
        }
        let r = r2.sqrt();
        let cos = n.dot(d) / r;
        if !(cos > 0.0) {
            return [0.0; 3];
        }
        let i = self.intensity_towards(-d / r);
        i.map(|c| c * cos / r2)
    }

    /// Solid-angle integral of the falloff, `∫ f dω` (sr): `4π` for a point light.
    pub fn solid_angle_weight(&self) -> f64 {
        let tau = std::f64::consts::TAU;
        match self.kind {
            LightKind::Point => 2.0 * tau,
            LightKind::Spot { inner, outer, .. } => {
                let (ci, co) = (inner.cos(), outer.cos());
                tau * ((1.0 - ci) + (ci - co).max(0.0) / 3.0)
            }
        }
    }

    /// Total emitted power `Φ` (W per channel), exact (module docs).
    pub fn power(&self) -> [f64; 3] {
        let w = self.solid_angle_weight();
        self.intensity.0.map(|c| c * w)
    }

    /// The light moved by a translate + uniform scale + rotation `m` (directions are
    /// renormalised; `None` if the result is degenerate).
    pub fn transformed(&self, m: &glam::DMat4) -> Option<Self> {
        let mut l = self.clone();
        l.position = m.transform_point3(self.position);
        if let LightKind::Spot { direction, .. } = &mut l.kind {
            *direction = m.transform_vector3(*direction).try_normalize()?;
        }
        Some(l)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Power by midpoint quadrature of the falloff over μ = cos.
    fn power_numeric(l: &Light) -> f64 {
        let n = 200_000;
        let axis = match l.kind {
            LightKind::Spot { direction, .. } => direction,
            _ => DVec3::Z,
        };
        let t = axis.any_orthonormal_vector();
        let mut s = 0.0;
        for k in 0..n {
            let mu = -1.0 + 2.0 * (k as f64 + 0.5) / n as f64;
            let dir = axis * mu + t * (1.0 - mu * mu).max(0.0).sqrt();
            s += l.falloff(dir);
        }
        2.0 * PI * s * 2.0 / n as f64 * l.intensity.0[0]
    }

    #[test]
    fn power_closed_form_matches_quadrature() {
        let cases = [
            (0.0, 0.5),
            (0.3, 0.9),
            (0.5, 0.5),
            (1.0, PI),
            (PI, PI),
            (0.2, 2.5),
        ];
        for (inner, outer) in cases {
            let l = Light::spot(
                "s",
                DVec3::ZERO,
                DVec3::new(1.0, 2.0, -0.5),
                inner,
                outer,
                Rgb::grey(2.0),
            );
            l.validate("t").unwrap();
            let exact = l.power()[0];
            let num = power_numeric(&l);
            assert!(
                (exact - num).abs() < 2e-4 * exact.max(1e-3),
                "{inner} {outer}: {exact} vs {num}"
            );
        }
        let p = Light::point("p", DVec3::ONE, Rgb::grey(1.0));
        assert!((p.power()[0] - 4.0 * PI).abs() < 1e-12);
    }

    #[test]
    fn validation_names_the_light() {
        let bad = [
            Light::point("a", DVec3::new(f64::NAN, 0.0, 0.0), Rgb::grey(1.0)),
            Light::point("a", DVec3::ZERO, Rgb::grey(-1.0)),
            Light::spot("a", DVec3::ZERO, DVec3::ZERO, 0.1, 0.2, Rgb::grey(1.0)),
            Light::spot("a", DVec3::ZERO, DVec3::Z, 0.1, 0.0, Rgb::grey(1.0)),
            Light::spot("a", DVec3::ZERO, DVec3::Z, 0.1, 3.5, Rgb::grey(1.0)),
            Light::spot("a", DVec3::ZERO, DVec3::Z, 0.5, 0.2, Rgb::grey(1.0)),
            Light::spot("a", DVec3::ZERO, DVec3::Z, f64::NAN, 0.2, Rgb::grey(1.0)),
        ];
        for l in bad {
            let e = l.validate("f.toml").unwrap_err();
            assert!(e.to_string().contains("light \"a\""), "{e}");
        }
    }

    #[test]
    fn irradiance_inverse_square_and_cosine() {
        let l = Light::spot(
            "s",
            DVec3::new(0.0, 0.0, 2.0),
            -DVec3::Z,
            0.2,
            0.4,
            Rgb::grey(3.0),
        );
        let e = l.irradiance_at(DVec3::ZERO, DVec3::Z);
        assert!((e[0] - 3.0 / 4.0).abs() < 1e-15);
        // Outside the cone: nothing; behind the surface: nothing.
        assert_eq!(
            l.irradiance_at(DVec3::new(5.0, 0.0, 0.0), DVec3::Z),
            [0.0; 3]
        );
        assert_eq!(l.irradiance_at(DVec3::ZERO, -DVec3::Z), [0.0; 3]);
        // At the light itself: finite zero.
        assert_eq!(l.irradiance_at(l.position, DVec3::Z), [0.0; 3]);
    }
}
