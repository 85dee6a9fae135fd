//! Direct incident irradiance at the sender points (Meshless §3.3: "visibility from
//! the light source to the sample points is determined using a ray tracer, but any
//! other direct illumination approach could be used as well").
//!
//! - [`DirectLighting::Lights`]: punctual point and spot lights (`wavelux-scene`
//!   [`Light`]), one shadow ray per light and point: `E = I(ω) cos θ / d²`;
//! - [`DirectLighting::Emitters`]: the scene's emitting sides by next-event estimation,
//!   `samples` points drawn uniformly by area per sender point, each point with its own
//!   seeded stream: `E ≈ (A/N) Σ L_e cos θ_x cos θ_y V / d²`, `L_e = E_e/π`;
//! - [`DirectLighting::Uniform`]: the same irradiance everywhere (tests: the furnace);
//! - [`DirectLighting::Sum`]: several of them (a scene's lights and emitters).

use glam::DVec3;
use rand::RngExt;
use rayon::prelude::*;
use wavelux_scene::{Light, LightKind};

use crate::MeshlessError;
use crate::query::SurfaceQuery;
use crate::sample::rng_for;

/// Stream tag of the emitter samples.
const TAG_NEE: u64 = 5;

/// A direct-lighting method.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum DirectLighting {
    /// Punctual lights with shadow rays.
    Lights(Vec<Light>),
    /// Area emitters by next-event estimation.
    Emitters {
        /// Light samples per point.
        samples: usize,
        /// Seed.
        seed: u64,
    },
    /// Uniform irradiance (W/m², RGB) at every point, unoccluded.
    Uniform([f64; 3]),
    /// The sum of several methods (e.g. a scene's punctual lights and its emitters).
    Sum(Vec<DirectLighting>),
}

/// Checks lights one by one with typed errors naming the light.
///
/// # Errors
/// [`MeshlessError::Light`] for a non-finite position or intensity, a negative
/// intensity, a zero spot direction or a cone angle outside `(0, π]`.
pub fn validate_lights(lights: &[Light]) -> Result<(), MeshlessError> {
    for (index, l) in lights.iter().enumerate() {
        let fail = |reason: String| MeshlessError::Light {
            index,
            name: l.name.clone(),
            reason,
        };
        if !l.position.is_finite() {
            return Err(fail(format!("position {:?} is not finite", l.position)));
        }
        for c in l.intensity.0 {
            if !c.is_finite() {
                return Err(fail(format!("intensity {c} is not finite")));
            }
            if c < 0.0 {
                return Err(fail(format!("intensity {c} is negative")));
            }
        }
        if let LightKind::Spot {
            direction,
            inner,
            outer,
        } = l.kind
        {
            if !direction.is_finite() || (direction.length() - 1.0).abs() > 1e-9 {
                return Err(fail("zero or non-finite spot direction".into()));
            }
            if !(outer > 0.0 && outer <= std::f64::consts::PI) {
                return Err(fail(format!("cone angle {outer} rad outside (0, π]")));
            }
            if !(inner >= 0.0 && inner <= outer) {
                return Err(fail(format!(
                    "inner angle {inner} rad outside [0, {outer}]"
                )));
            }
        }
    }
    Ok(())
}

impl DirectLighting {
    /// Checks the method's parameters (lights, sample count, uniform values) and that
    /// `query` can sample emitters when they are asked for.
    ///
    /// # Errors
    /// As [`DirectLighting::irradiance`].
    pub fn validate<Q: SurfaceQuery + ?Sized>(&self, query: &Q) -> Result<(), MeshlessError> {
        match self {
            Self::Lights(lights) => validate_lights(lights),
            Self::Emitters { samples, .. } => {
                if *samples == 0 {
                    return Err(MeshlessError::config("emitter samples", "must be >= 1"));
                }
                if query.sample_emitter([0.5; 3]).is_none() {
                    return Err(MeshlessError::Scene {
                        scene: String::new(),
                        reason:
                            "no emitter that can be sampled by area (triangles and parallelograms)"
                                .into(),
                    });
                }
                Ok(())
            }
            Self::Uniform(v) => {
                if v.iter().all(|c| c.is_finite()) {
                    Ok(())
                } else {
                    Err(MeshlessError::config("uniform irradiance", "not finite"))
                }
            }
            Self::Sum(parts) => parts.iter().try_for_each(|p| p.validate(query)),
        }
    }

    /// Irradiance (W/m², RGB) at one point `(x, n)`; `key` selects the random stream of
    /// the emitter samples (a point index, or a hash of the position). Call
    /// [`DirectLighting::validate`] first: invalid parameters give zero here.
    pub fn irradiance_at<Q: SurfaceQuery + ?Sized>(
        &self,
        query: &Q,
        x: DVec3,
        n: DVec3,
        key: u64,
    ) -> [f64; 3] {
        let off = query.offset();
        let o = x + n * off;
        match self {
            Self::Lights(lights) => {
                let mut e = [0.0; 3];
                for l in lights {
                    let v = l.irradiance_at(x, n);
                    if v == [0.0; 3] || query.occluded(o, l.position) {
                        continue;
                    }
                    for c in 0..3 {
                        e[c] += v[c];
                    }
                }
                e
            }
            Self::Emitters { samples, seed } => {
                if *samples == 0 {
                    return [0.0; 3];
                }
                let mut rng = rng_for(*seed, TAG_NEE, key);
                let mut e = [0.0; 3];
                for _ in 0..*samples {
                    let u = [rng.random(), rng.random(), rng.random()];
                    let Some(s) = query.sample_emitter(u) else {
                        continue;
                    };
                    let d = s.point - x;
                    let r2 = d.length_squared();
                    if !(r2 > 0.0) {
                        continue;
                    }
                    let r = r2.sqrt();
                    let (cx, cy) = (n.dot(d) / r, -s.normal.dot(d) / r);
                    if cx <= 0.0 || cy <= 0.0 {
                        continue;
                    }
                    if query.occluded(o, s.point + s.normal * off) {
                        continue;
                    }
                    let g = cx * cy / r2 * s.total_area * std::f64::consts::FRAC_1_PI;
                    for c in 0..3 {
                        e[c] += s.exitance[c] * g;
                    }
                }
                e.map(|v| v / *samples as f64)
            }
            Self::Uniform(v) => *v,
            Self::Sum(parts) => {
                let mut e = [0.0; 3];
                for (k, p) in parts.iter().enumerate() {
                    let v = p.irradiance_at(query, x, n, key ^ ((k as u64) << 56));
                    for c in 0..3 {
                        e[c] += v[c];
                    }
                }
                e
            }
        }
    }

    /// Irradiance (W/m², RGB) at each point `(x, n)` (point `k` draws from stream `k`).
    ///
    /// # Errors
    /// [`MeshlessError::Light`] for invalid lights; [`MeshlessError::Config`] for zero
    /// emitter samples or non-finite uniform values; [`MeshlessError::Scene`] when
    /// emitters are asked for but the query has none to sample.
    pub fn irradiance<Q: SurfaceQuery + ?Sized>(
        &self,
        query: &Q,
        points: &[(DVec3, DVec3)],
    ) -> Result<Vec<[f64; 3]>, MeshlessError> {
        self.validate(query)?;
        Ok(points
            .par_iter()
            .enumerate()
            .map(|(k, &(x, n))| self.irradiance_at(query, x, n, k as u64))
            .collect())
    }
}
