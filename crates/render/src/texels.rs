//! Texel grids: the error of a radiosity *function* over every real surface point
//! (issue 12 §1 (a)), measured like a lightmap.
//!
//! A [`TexelGrid`] lays points over every lit side of every scene surface at a fixed
//! density per m² (the centres of equal-area cells of each primitive's
//! parametrization, real points only; see `area::AreaSampler::grid`), each carrying the
//! area it stands for. Any [`RadiosityField`] is evaluated at the texels by a short
//! probe ray along the side's normal ([`TexelGrid::evaluate`]), so every method that
//! renders is measured on the same points; the path tracer estimates the same points
//! with standard errors ([`crate::PathTracer::texels`]).
//!
//! The metric ([`TexelGrid::compare`]) is the area-weighted relative L1 error of the
//! *reflected* radiosity,
//! `Σ_t A_t Σ_c |B_tc − B̂_tc| / Σ_t A_t Σ_c |B̂_tc − E_tc|`
//! (the emitters' `E` is exact for every method and would otherwise dilute it, as in
//! the surface-average metric). Its *noise floor* is what a perfect answer would score
//! against the noisy reference, `Σ_t A_t Σ_c σ_tc √(2/π) / (same denominator)`
//! (`E|N(0, σ²)| = σ√(2/π)`): errors near or below it are not resolved.

use glam::DVec3;
use rayon::prelude::*;
use serde::Serialize;
use wavelux_geometry::Ray;
use wavelux_scene::{Scene, Sidedness};

use crate::area::AreaSampler;
use crate::field::RadiosityField;
use crate::reference::{SurfaceEstimate, side_mat};
use crate::{RenderError, invalid};

/// One texel: a point on one lit side of a scene surface.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Texel {
    /// Index of the scene surface.
    pub surface: usize,
    /// The back side of a two-sided surface (else the front).
    pub back: bool,
    /// Index of the primitive in `Scene::primitives` order (the path tracer's ids).
    pub prim: u32,
    /// Position (scene units).
    pub point: [f64; 3],
    /// Unit normal of the lit side.
    pub normal: [f64; 3],
    /// Area the texel stands for (scene units²); the areas of a side's texels sum to
    /// its area.
    pub area: f64,
    /// Emitted exitance of the side (W/m², RGB).
    pub emission: [f64; 3],
}

/// Texels over every lit side of a scene at a fixed density.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TexelGrid {
    /// Requested density (texels per scene unit²).
    pub density: f64,
    /// The texels, surface by surface, front side before back side.
    pub texels: Vec<Texel>,
}

/// A field's values at the texels.
#[derive(Debug, Clone, PartialEq)]
pub struct TexelValues {
    /// Radiosity per texel (W/m², RGB); zero where unresolved.
    pub values: Vec<[f64; 3]>,
    /// Texels whose probe ray did not land on the texel's own surface side (counted
    /// with radiosity zero, i.e. as fully wrong).
    pub unresolved: usize,
}

/// Error of texel values against a reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct TexelMetrics {
    /// Area-weighted relative L1 error of the reflected radiosity (module docs).
    pub relative_l1: f64,
    /// Expected score of an exact answer against the noisy reference (module docs);
    /// `None` when the reference has no standard errors.
    pub noise_floor: Option<f64>,
    /// Largest per-texel relative error `Σ_c |Δ| / Σ_c |B̂ − E|` among texels whose
    /// reflected radiosity is at least 1 % of the area-weighted mean.
    pub max_relative: f64,
    /// Number of texels.
    pub texels: usize,
}

impl TexelGrid {
    /// Texels over every lit side of `scene` at `density` texels per scene unit²
    /// (front sides of all surfaces, back sides of two-sided ones).
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for a density that is not finite and positive (or
    /// that would give more than 10⁸ texels); [`RenderError::Scene`] for invalid
    /// geometry or materials, or a primitive that cannot be parametrized by area.
    pub fn new(scene: &Scene, density: f64) -> Result<Self, RenderError> {
        if !(density.is_finite() && density > 0.0) {
            return Err(invalid(
                "texel density",
                format!("{density} is not a positive number of texels per unit²"),
            ));
        }
        if density * scene.total_area() > 1e8 {
            return Err(invalid(
                "texel density",
                format!(
                    "{density} per unit² gives more than 10⁸ texels on {} unit²",
                    scene.total_area()
                ),
            ));
        }
        let prims = scene
            .primitives(&scene.name)
            .map_err(|e| RenderError::Scene(e.to_string()))?;
        let mut sides = Vec::with_capacity(scene.surfaces.len());
        for s in &scene.surfaces {
            let front = side_mat(scene, s.material, &s.name)?;
            let back = match s.sides {
                Sidedness::TwoSided { back } => Some(side_mat(scene, back, &s.name)?),
                _ => None,
            };
            sides.push((front, back));
        }
        let grids = prims
            .par_iter()
            .map(|(_, p)| AreaSampler::new(p)?.grid(p, density))
            .collect::<Result<Vec<_>, _>>()?;
        let mut texels = Vec::new();
        for back in [false, true] {
            for (k, ((surface, _), grid)) in prims.iter().zip(&grids).enumerate() {
                let (front, back_mat) = sides[*surface];
                let mat = if back {
                    match back_mat {
                        Some(m) => m,
                        None => continue,
                    }
                } else {
                    front
                };
                for &(x, n, a) in grid {
                    let n = if back { -n } else { n };
                    texels.push(Texel {
                        surface: *surface,
                        back,
                        prim: k as u32,
                        point: x.to_array(),
                        normal: n.to_array(),
                        area: a,
                        emission: mat.e,
                    });
                }
            }
        }
        texels.sort_by_key(|t| (t.surface, t.back));
        Ok(Self { density, texels })
    }

    /// Number of texels.
    pub fn len(&self) -> usize {
        self.texels.len()
    }

    /// True if there are no texels.
    pub fn is_empty(&self) -> bool {
        self.texels.is_empty()
    }

    /// Total area the texels stand for (scene units²).
    pub fn area(&self) -> f64 {
        self.texels.iter().map(|t| t.area).sum()
    }

    /// `field`'s radiosity at every texel: a probe ray from `point + δ·normal` along
    /// `−normal` (`δ = 1e-6 ×` the field's scene diagonal) must land on the texel's
    /// surface and side; otherwise the texel is unresolved. Parallel and deterministic.
    pub fn evaluate<F: RadiosityField + ?Sized>(&self, field: &F) -> TexelValues {
        let diag = field.accel().bounds().diagonal().length();
        let delta = 1e-6
            * if diag.is_finite() && diag > 0.0 {
                diag
            } else {
                1.0
            };
        let vals: Vec<Option<[f64; 3]>> = self
            .texels
            .par_iter()
            .with_min_len(64)
            .map(|t| {
                let n = DVec3::from_array(t.normal);
                let ray = Ray {
                    origin: DVec3::from_array(t.point) + n * delta,
                    dir: -n,
                };
                let hit = field.accel().closest_hit(&ray, 0.0, 3.0 * delta)?;
                let p = field.resolve(&hit)?;
                (p.surface == t.surface && p.normal.dot(n) > 0.0).then(|| field.radiosity(&p))
            })
            .collect();
        let unresolved = vals.iter().filter(|v| v.is_none()).count();
        TexelValues {
            values: vals.into_iter().map(|v| v.unwrap_or([0.0; 3])).collect(),
            unresolved,
        }
    }

    /// The error of `values` against `reference` (one entry per texel each); with the
    /// reference's standard errors (`reference_se`) the noise floor is reported.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] if a slice's length differs from the texel count or
    /// the reference has no reflected radiosity.
    pub fn compare(
        &self,
        values: &[[f64; 3]],
        reference: &[[f64; 3]],
        reference_se: Option<&[[f64; 3]]>,
    ) -> Result<TexelMetrics, RenderError> {
        let n = self.texels.len();
        if values.len() != n || reference.len() != n || reference_se.is_some_and(|s| s.len() != n) {
            return Err(invalid(
                "texel values",
                format!(
                    "{} values, {} reference values for {n} texels",
                    values.len(),
                    reference.len()
                ),
            ));
        }
        let reflected = |i: usize| -> f64 {
            (0..3)
                .map(|c| (reference[i][c] - self.texels[i].emission[c]).abs())
                .sum()
        };
        let (mut num, mut den, mut noise, mut area) = (0.0, 0.0, 0.0, 0.0);
        for (i, t) in self.texels.iter().enumerate() {
            num += t.area
                * (0..3)
                    .map(|c| (values[i][c] - reference[i][c]).abs())
                    .sum::<f64>();
            den += t.area * reflected(i);
            area += t.area;
            if let Some(se) = reference_se {
                noise += t.area * se[i].iter().sum::<f64>();
            }
        }
        if !(den > 0.0 && den.is_finite()) {
            return Err(invalid(
                "texel reference",
                "no reflected radiosity (the scene is dark or the reference is not finite)",
            ));
        }
        let mean = den / area;
        let max_relative = (0..n)
            .filter(|&i| reflected(i) >= 0.01 * mean)
            .map(|i| {
                (0..3)
                    .map(|c| (values[i][c] - reference[i][c]).abs())
                    .sum::<f64>()
                    / reflected(i)
            })
            .fold(0.0, f64::max);
        Ok(TexelMetrics {
            relative_l1: num / den,
            noise_floor: reference_se.map(|_| noise * (2.0 / std::f64::consts::PI).sqrt() / den),
            max_relative,
            texels: n,
        })
    }

    /// [`TexelGrid::compare`] against path-traced estimates (means and their standard
    /// errors).
    ///
    /// # Errors
    /// As [`TexelGrid::compare`].
    pub fn compare_estimates(
        &self,
        values: &[[f64; 3]],
        reference: &[SurfaceEstimate],
    ) -> Result<TexelMetrics, RenderError> {
        let m: Vec<[f64; 3]> = reference.iter().map(|e| e.mean).collect();
        let se: Vec<[f64; 3]> = reference.iter().map(|e| e.std_error).collect();
        self.compare(values, &m, Some(&se))
    }
}
