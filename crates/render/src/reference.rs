//! A Monte Carlo path tracer for diffuse scenes: the ground truth for scenes without
//! closed forms.
//!
//! For Lambertian surfaces the radiosity equation `B(x) = E(x) + ρ(x)·H(x)` with
//! irradiance `H(x) = ∫_Ω B(y(ω))/π · cos θ dω` is estimated by a random walk: one
//! cosine-distributed direction per bounce (pdf `cos θ/π`, so `H(x)` is estimated by
//! `B(y)` at the hit `y`), `B(y)` estimated recursively, and Russian roulette after
//! `rr_depth` bounces with survival probability `min(0.95, max_c throughput_c)`
//! (unbiased: survivors are divided by it). Rays that escape or hit the back of a
//! one-sided surface (a black occluder) contribute nothing. Emitted light is gathered
//! by next-event estimation (one shadow ray per vertex to a point drawn uniformly by
//! area over all emitting sides, of any shape: planar, trimmed analytic, Bézier)
//! combined with the emission the walk finds by the balance heuristic (Veach's
//! multiple importance sampling), which cuts the variance for small lights and stays
//! bounded in corners. Points are drawn by area through [`crate::area`]'s exact
//! samplers (equal-area maps with rejection against trims; Jacobian-bound rejection on
//! Bézier patches), with per-point normals from the parametrizations.
//!
//! - Per-surface averages: points uniform by area on one side of a surface (the front
//!   side is the quantity `crate::side_average` reports for a solution), one
//!   walk each; the mean and its standard error `s/√N` per channel.
//! - Per-point radiosity and images (pixel value `B/π`, radiance of a Lambertian
//!   surface).
//!
//! Determinism: every sample index (point or pixel) draws from its own stream derived
//! from `(seed, surface or pixel, index)`, and sums are reduced in a fixed order, so
//! results are bitwise identical for any number of threads.
//!
//! Punctual lights (`Scene::lights`, point and spot) are added by next-event
//! estimation at every vertex (one shadow ray per light: `I(ω) cos θ / d²`); the walk
//! cannot hit them, so no weighting is needed. [`PathTracer::indirect_irradiance_at`]
//! estimates the *indirect* irradiance only (Meshless §3: what the meshless method
//! represents): the first vertex takes neither light samples nor the emission its walk
//! hits, so only paths with at least one bounce count.
//!
//! Materials: reflectance and emission times their texture means (the same constants
//! the solver uses); a Ward lobe is ignored here (diffuse transport only: scenes with
//! Ward lobes or cosine-power emitters are traced by [`glossy::GlossyTracer`]); directional
//! (cosine-power) emitters are rejected; participating media are ignored.

pub mod glossy;
pub mod volume;

use glam::DVec3;
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use serde::Serialize;
use wavelux_geometry::{Accel, Hit, Ray};
use wavelux_scene::{EmissionProfile, Light, Scene, Sidedness};

use crate::area::AreaSampler;
use crate::camera::View;
use crate::image::Image;
use crate::render::SECONDARY_EPS_REL;
use crate::sampling::{cosine_dir, rng_for};
use crate::texels::TexelGrid;
use crate::{RenderError, invalid};

/// Reflectance and emission of one surface side.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct SideMat {
    pub(crate) rho: [f64; 3],
    pub(crate) e: [f64; 3],
}

/// Options of the random walks.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ReferenceOptions {
    /// Bounces before Russian roulette starts.
    pub rr_depth: usize,
    /// Hard cap on the path length (a safety net; with roulette the probability of
    /// reaching it is below `0.95^(cap − rr_depth)`).
    pub max_depth: usize,
    /// Seed.
    pub seed: u64,
}

impl Default for ReferenceOptions {
    /// Roulette after 3 bounces, cap 4096, seed 0.
    fn default() -> Self {
        Self {
            rr_depth: 3,
            max_depth: 4096,
            seed: 0,
        }
    }
}

/// A Monte Carlo estimate with its standard error (per RGB channel).
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct SurfaceEstimate {
    /// Sample mean (W/m²).
    pub mean: [f64; 3],
    /// Standard error of the mean, `s/√N` (W/m²).
    pub std_error: [f64; 3],
    /// Number of samples `N`.
    pub samples: u64,
}

/// An emitting side: primitive, back side?, exitance.
type AreaLight = (usize, bool, [f64; 3]);

/// Running sums of a chunk of samples: `(Σ b, Σ b²)` per channel.
type Sums = ([f64; 3], [f64; 3]);

/// The path tracer over a scene's exact geometry.
#[derive(Debug)]
pub struct PathTracer {
    accel: Accel,
    prim_surface: Vec<usize>,
    sides: Vec<[Option<SideMat>; 2]>,
    surface_prims: Vec<Vec<usize>>,
    eps: f64,
    /// Area sampler per primitive (`Err`: why it cannot be sampled).
    samplers: Vec<Result<AreaSampler, String>>,
    /// Emitting sides for next-event estimation: (primitive, back side?, E), with the
    /// cumulative area; `None` when some emitter cannot be area-sampled.
    lights: Option<(Vec<AreaLight>, Vec<f64>)>,
    /// Punctual lights (next-event estimation only).
    punctual: Vec<Light>,
}

/// Reflectance and emission of a material (texture means applied), validated.
pub(crate) fn side_mat(scene: &Scene, id: usize, name: &str) -> Result<SideMat, RenderError> {
    let m = scene
        .materials
        .get(id)
        .ok_or_else(|| RenderError::Scene(format!("surface {name:?}: material {id} missing")))?;
    if !matches!(m.emission_profile, EmissionProfile::Lambertian) && m.is_emitter() {
        return Err(RenderError::Scene(format!(
            "material {:?}: directional emitters are not supported by the diffuse reference",
            m.name
        )));
    }
    let (rho, e) = m
        .checked_diffuse_means(&scene.textures)
        .map_err(|why| RenderError::Scene(format!("material {:?}: {why}", m.name)))?;
    Ok(SideMat { rho, e })
}

fn max3(v: [f64; 3]) -> f64 {
    v[0].max(v[1]).max(v[2])
}

impl PathTracer {
    /// Builds the accelerator over the scene's exact primitives.
    ///
    /// # Errors
    /// [`RenderError::Scene`] for invalid geometry or materials, an empty scene, or
    /// directional emitters.
    pub fn new(scene: &Scene) -> Result<Self, RenderError> {
        let prims = scene
            .primitives(&scene.name)
            .map_err(|e| RenderError::Scene(e.to_string()))?;
        if prims.is_empty() {
            return Err(RenderError::Scene("the scene has no surfaces".into()));
        }
        let mut sides = Vec::with_capacity(scene.surfaces.len());
        for s in &scene.surfaces {
            let front = side_mat(scene, s.material, &s.name)?;
            let back = match s.sides {
                Sidedness::TwoSided { back } => Some(side_mat(scene, back, &s.name)?),
                _ => None,
            };
            sides.push([Some(front), back]);
        }
        let mut surface_prims = vec![Vec::new(); scene.surfaces.len()];
        let mut prim_surface = Vec::with_capacity(prims.len());
        let mut list = Vec::with_capacity(prims.len());
        for (k, (s, p)) in prims.into_iter().enumerate() {
            surface_prims[s].push(k);
            prim_surface.push(s);
            list.push(p);
        }
        let samplers: Vec<Result<AreaSampler, String>> = list
            .iter()
            .map(|p| AreaSampler::new(p).map_err(|e| e.to_string()))
            .collect();
        let mut lights = Some((Vec::new(), Vec::new()));
        let mut tot = 0.0;
        for (k, p) in list.iter().enumerate() {
            for back in [false, true] {
                let Some(m) = sides[prim_surface[k]][usize::from(back)] else {
                    continue;
                };
                if max3(m.e) <= 0.0 {
                    continue;
                }
                if samplers[k].is_err() {
                    lights = None;
                }
                if let Some((l, cdf)) = &mut lights {
                    tot += p.area();
                    l.push((k, back, m.e));
                    cdf.push(tot);
                }
            }
        }
        let accel = Accel::build(list).map_err(|e| RenderError::Scene(e.to_string()))?;
        let diag = accel.bounds().diagonal().length();
        for l in &scene.lights {
            l.validate(&scene.name)
                .map_err(|e| RenderError::Scene(e.to_string()))?;
        }
        Ok(Self {
            accel,
            prim_surface,
            sides,
            surface_prims,
            eps: SECONDARY_EPS_REL * diag,
            samplers,
            lights,
            punctual: scene.lights.clone(),
        })
    }

    /// The accelerator (primitive ids index the scene's flattened primitives).
    pub fn accel(&self) -> &Accel {
        &self.accel
    }

    /// `(reflectance, emitted exitance)` of one side of a surface (texture means
    /// applied, as the path tracer uses them); `None` for the black back of a one-sided
    /// surface or an index out of range.
    pub fn side_material(&self, surface: usize, back: bool) -> Option<([f64; 3], [f64; 3])> {
        let m = self.sides.get(surface)?[usize::from(back)]?;
        Some((m.rho, m.e))
    }

    /// Surface index and side material of a hit (`None`: black back side).
    fn side_of(&self, hit: &Hit) -> Option<(usize, SideMat, DVec3)> {
        let s = *self.prim_surface.get(hit.prim as usize)?;
        let [front, back] = self.sides[s];
        if hit.front {
            Some((s, front?, hit.normal))
        } else {
            Some((s, back?, -hit.normal))
        }
    }

    /// One-sample estimate of the irradiance `H(x)` (W/m²) at `x` on the side with
    /// unit normal `n` (`prim`: the primitive `x` lies on, skipped by shadow rays).
    ///
    /// With next-event estimation (every emitter planar): at each vertex the emitted
    /// part `∫ E(y)/π cos θ_x cos θ_y V / r² dA_y` is estimated from one point drawn
    /// uniformly by area over all emitting sides, and the walk continues with
    /// cosine-distributed directions collecting only reflected light (emission found
    /// by the walk is not added, so nothing is counted twice). Without it, emission is
    /// collected where the walk hits it.
    fn irradiance(
        &self,
        x: DVec3,
        n: DVec3,
        prim: Option<u32>,
        opts: &ReferenceOptions,
        rng: &mut Pcg64,
        indirect_only: bool,
    ) -> [f64; 3] {
        let mut out = [0.0; 3];
        let mut thr = [1.0; 3];
        let (mut o, mut nn, mut pid) = (x, n, prim);
        for depth in 0..opts.max_depth {
            let first_skipped = indirect_only && depth == 0;
            if !first_skipped {
                if let Some(d) = self.direct(o, nn, pid, rng) {
                    for c in 0..3 {
                        out[c] += thr[c] * d[c];
                    }
                }
                let d = self.punctual(o, nn, pid);
                for c in 0..3 {
                    out[c] += thr[c] * d[c];
                }
            }
            let d = cosine_dir(nn, rng.random(), rng.random());
            let ray = Ray {
                origin: o + nn * self.eps,
                dir: d,
            };
            let Some(hit) = self.accel.closest_hit(&ray, self.eps, f64::INFINITY) else {
                break;
            };
            let Some((_, m, hn)) = self.side_of(&hit) else {
                break;
            };
            // Emission found by the walk: all of it without light sampling, else its
            // balance-heuristic share (Veach's MIS: the light sample takes the rest).
            let w = match &self.lights {
                None => 1.0,
                Some((_, cdf)) if max3(m.e) > 0.0 => {
                    let tot = cdf.last().copied().unwrap_or(0.0);
                    let pb = nn.dot(d).max(0.0) / std::f64::consts::PI;
                    let cy = (-d.dot(hn)).max(1e-300);
                    let pl = hit.t * hit.t / (cy * tot);
                    pb / (pb + pl)
                }
                Some(_) => 0.0,
            };
            let w = if first_skipped { 0.0 } else { w };
            for c in 0..3 {
                out[c] += thr[c] * m.e[c] * w;
                thr[c] *= m.rho[c];
            }
            if depth + 1 >= opts.rr_depth {
                let q = max3(thr).min(0.95);
                if q <= 0.0 || rng.random::<f64>() >= q {
                    break;
                }
                thr = thr.map(|t| t / q);
            } else if max3(thr) <= 0.0 {
                break;
            }
            o = hit.point;
            nn = hn;
            pid = Some(hit.prim);
        }
        out
    }

    /// Irradiance from the punctual lights at `x` (one shadow ray each).
    fn punctual(&self, x: DVec3, n: DVec3, prim: Option<u32>) -> [f64; 3] {
        let mut e = [0.0; 3];
        for l in &self.punctual {
            let v = l.irradiance_at(x, n);
            if v == [0.0; 3] || self.accel.occluded(x, l.position, [prim, None]) {
                continue;
            }
            for c in 0..3 {
                e[c] += v[c];
            }
        }
        e
    }

    /// Light-sampling estimate of the emitted irradiance at `x` (None without NEE).
    fn direct(&self, x: DVec3, n: DVec3, prim: Option<u32>, rng: &mut Pcg64) -> Option<[f64; 3]> {
        let (lights, cdf) = self.lights.as_ref()?;
        let tot = *cdf.last()?;
        let u = rng.random::<f64>() * tot;
        let j = cdf.partition_point(|&c| c <= u).min(lights.len() - 1);
        let (k, back, e) = lights[j];
        let (y, ny) = self.sample_prim(k, rng).ok()?;
        let ny = if back { -ny } else { ny };
        let d = y - x;
        let r2 = d.length_squared();
        if r2 <= 0.0 {
            return Some([0.0; 3]);
        }
        let r = r2.sqrt();
        let cx = n.dot(d) / r;
        let cy = -ny.dot(d) / r;
        if cx <= 0.0 || cy <= 0.0 {
            return Some([0.0; 3]);
        }
        if self.accel.occluded(x, y, [prim, Some(k as u32)]) {
            return Some([0.0; 3]);
        }
        // Balance heuristic with the cosine-sampled walk (pdfs in solid angle):
        // light `r²/(cos θ_y A)`, walk `cos θ_x/π`. The weighted estimate
        // `E cos θ_x/π / (p_light + p_walk)` is bounded by `E` (no corner singularity).
        let pl = r2 / (cy * tot);
        let pb = cx / std::f64::consts::PI;
        let g = cx / std::f64::consts::PI / (pl + pb);
        Some(e.map(|v| v * g))
    }

    /// One-sample estimate of `B(x) = E + ρ·H(x)` on a side.
    fn radiosity_sample(
        &self,
        x: DVec3,
        n: DVec3,
        prim: Option<u32>,
        m: SideMat,
        opts: &ReferenceOptions,
        rng: &mut Pcg64,
    ) -> [f64; 3] {
        if max3(m.rho) <= 0.0 {
            return m.e;
        }
        let h = self.irradiance(x, n, prim, opts, rng, false);
        std::array::from_fn(|c| m.e[c] + m.rho[c] * h[c])
    }

    /// Uniform-by-area point on primitive `k`, with its front normal there.
    fn sample_prim(&self, k: usize, rng: &mut Pcg64) -> Result<(DVec3, DVec3), RenderError> {
        let sampler = self.samplers[k]
            .as_ref()
            .map_err(|e| RenderError::Scene(e.clone()))?;
        let s = sampler.sample(&self.accel.primitives()[k], rng)?;
        Ok((s.point, s.normal))
    }

    /// Area-average radiosity of a surface's front side from `samples` uniformly
    /// distributed points (one walk each): [`PathTracer::side_average`] of the front.
    ///
    /// # Errors
    /// As [`PathTracer::side_average`].
    pub fn surface_average(
        &self,
        surface: usize,
        samples: u64,
        opts: &ReferenceOptions,
    ) -> Result<SurfaceEstimate, RenderError> {
        self.side_average(surface, false, samples, opts)
    }

    /// Area-average radiosity of one side of a surface (`back`: the side opposite the
    /// shape's orientation, lit only on two-sided surfaces) from `samples` points
    /// uniform by area over the surface's primitives (any shape), one walk each.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for a bad surface index, zero samples or a back side
    /// that does not exist (one-sided surface); [`RenderError::Scene`] for a surface
    /// whose primitives cannot be area-sampled (a trimmed patch on a non-equal-area
    /// map).
    pub fn side_average(
        &self,
        surface: usize,
        back: bool,
        samples: u64,
        opts: &ReferenceOptions,
    ) -> Result<SurfaceEstimate, RenderError> {
        let prims = self
            .surface_prims
            .get(surface)
            .ok_or_else(|| invalid("surface", format!("{surface} out of range")))?;
        if samples == 0 {
            return Err(invalid("samples", "must be >= 1"));
        }
        if prims.is_empty() {
            return Err(RenderError::Scene(format!(
                "surface {surface} has no primitives"
            )));
        }
        let mat = self.sides[surface][usize::from(back)]
            .ok_or_else(|| invalid("side", "the back of a one-sided surface is black"))?;
        // Independent streams for the two sides.
        let stream = surface as u64 | (u64::from(back) << 48);
        let all = self.accel.primitives();
        let mut cdf = Vec::with_capacity(prims.len());
        let mut tot = 0.0;
        for &k in prims {
            tot += all[k].area();
            cdf.push(tot);
        }
        const CHUNK: u64 = 1024;
        let chunks = samples.div_ceil(CHUNK);
        let sums: Vec<Result<Sums, RenderError>> = (0..chunks)
            .into_par_iter()
            .map(|ch| {
                let mut s = [0.0; 3];
                let mut s2 = [0.0; 3];
                for i in ch * CHUNK..((ch + 1) * CHUNK).min(samples) {
                    let mut rng = rng_for(opts.seed, stream, i);
                    let u = rng.random::<f64>() * tot;
                    let j = cdf.partition_point(|&c| c <= u).min(prims.len() - 1);
                    let (x, n) = self.sample_prim(prims[j], &mut rng)?;
                    let n = if back { -n } else { n };
                    let pid = Some(prims[j] as u32);
                    let b = self.radiosity_sample(x, n, pid, mat, opts, &mut rng);
                    for c in 0..3 {
                        s[c] += b[c];
                        s2[c] += b[c] * b[c];
                    }
                }
                Ok((s, s2))
            })
            .collect();
        let mut s = [0.0; 3];
        let mut s2 = [0.0; 3];
        for r in sums {
            let (a, b) = r?;
            for c in 0..3 {
                s[c] += a[c];
                s2[c] += b[c];
            }
        }
        Ok(estimate(s, s2, samples))
    }

    /// [`PathTracer::surface_average`] for every surface (surfaces whose area cannot be
    /// sampled give an error in their slot).
    pub fn surface_averages(
        &self,
        samples: u64,
        opts: &ReferenceOptions,
    ) -> Vec<Result<SurfaceEstimate, RenderError>> {
        (0..self.sides.len())
            .map(|s| self.surface_average(s, samples, opts))
            .collect()
    }

    /// Radiosity at a point of a surface side with unit normal `n` (the side the
    /// normal points out of) from `paths` walks.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for a bad surface index, zero paths, a non-unit normal,
    /// or a back side that does not exist (one-sided surface).
    pub fn radiosity_at(
        &self,
        surface: usize,
        back: bool,
        x: DVec3,
        n: DVec3,
        paths: u64,
        opts: &ReferenceOptions,
    ) -> Result<SurfaceEstimate, RenderError> {
        let sides = self
            .sides
            .get(surface)
            .ok_or_else(|| invalid("surface", format!("{surface} out of range")))?;
        let m = sides[usize::from(back)]
            .ok_or_else(|| invalid("side", "the back of a one-sided surface is black"))?;
        if paths == 0 {
            return Err(invalid("paths", "must be >= 1"));
        }
        if !(x.is_finite() && (n.length() - 1.0).abs() < 1e-6) {
            return Err(invalid("point", "non-finite point or non-unit normal"));
        }
        let mut s = [0.0; 3];
        let mut s2 = [0.0; 3];
        let key = x
            .to_array()
            .iter()
            .fold(0u64, |a, v| a ^ v.to_bits().rotate_left(17));
        for i in 0..paths {
            let mut rng = rng_for(opts.seed ^ key, surface as u64, i);
            let b = self.radiosity_sample(x, n, None, m, opts, &mut rng);
            for c in 0..3 {
                s[c] += b[c];
                s2[c] += b[c] * b[c];
            }
        }
        Ok(estimate(s, s2, paths))
    }

    /// The indirect irradiance `H_ind` (W/m², RGB) at a point `x` with unit normal `n`
    /// (the side it faces) from `paths` walks that skip the first vertex's light
    /// samples and the emission its walk hits (module docs). `key` selects the random
    /// streams (use the point's index).
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for zero paths, a non-finite point or a non-unit normal.
    pub fn indirect_irradiance_at(
        &self,
        x: DVec3,
        n: DVec3,
        paths: u64,
        key: u64,
        opts: &ReferenceOptions,
    ) -> Result<SurfaceEstimate, RenderError> {
        if paths == 0 {
            return Err(invalid("paths", "must be >= 1"));
        }
        if !(x.is_finite() && (n.length() - 1.0).abs() < 1e-6) {
            return Err(invalid("point", "non-finite point or non-unit normal"));
        }
        let mut s = [0.0; 3];
        let mut s2 = [0.0; 3];
        for i in 0..paths {
            let mut rng = rng_for(opts.seed, key | (1 << 62), i);
            let h = self.irradiance(x, n, None, opts, &mut rng, true);
            for c in 0..3 {
                s[c] += h[c];
                s2[c] += h[c] * h[c];
            }
        }
        Ok(estimate(s, s2, paths))
    }

    /// The emitted radiance `E/π` at the primary hits, `spp × spp` samples at the
    /// centres of a regular grid per pixel (deterministic): where the light sources
    /// are in the image (the mask of [`Image::reflected_relative_l1`]).
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for `spp ∉ 1..=64`.
    pub fn emission_image(&self, view: &View, spp: usize) -> Result<Image, RenderError> {
        if !(1..=64).contains(&spp) {
            return Err(invalid("spp", format!("{spp} not in 1..=64")));
        }
        let (w, h) = (view.width, view.height);
        let k = 1.0 / (std::f64::consts::PI * (spp * spp) as f64);
        let rows: Vec<Vec<[f64; 3]>> = (0..h)
            .into_par_iter()
            .map(|y| {
                (0..w)
                    .map(|x| {
                        let mut acc = [0.0; 3];
                        for sy in 0..spp {
                            for sx in 0..spp {
                                let ray = view.ray(
                                    x as f64 + (sx as f64 + 0.5) / spp as f64,
                                    y as f64 + (sy as f64 + 0.5) / spp as f64,
                                );
                                if let Some(hit) = self.accel.closest_hit(&ray, 0.0, f64::INFINITY)
                                    && let Some((_, m, _)) = self.side_of(&hit)
                                {
                                    for c in 0..3 {
                                        acc[c] += m.e[c];
                                    }
                                }
                            }
                        }
                        acc.map(|v| v * k)
                    })
                    .collect()
            })
            .collect();
        let mut img = Image::new(w, h);
        for (y, r) in rows.into_iter().enumerate() {
            img.pixels[y * w..(y + 1) * w].copy_from_slice(&r);
        }
        Ok(img)
    }

    /// The *flat* pixels of `view` (for [`Image::flat_noise`]): pixels whose 5×5
    /// neighbourhood's centre rays all hit the same lit side of one non-emitting
    /// primitive (one face: a surface such as a block has several, meeting at
    /// edges), and are all fully lit or all fully shadowed as seen from 16 fixed
    /// points on the emitters (stratified by area; no shadow boundary or penumbra
    /// crosses the neighbourhood). Five, not three: the noise metric compares a pixel
    /// with its four neighbours, whose footprints (their jittered samples) reach 1.5
    /// pixels from its centre; with a 3×3 test an edge (a wall's corner, the light
    /// source's rim on the ceiling) half a pixel beyond a neighbour's centre entered
    /// its samples and the metric measured edges, not noise. Without light sampling
    /// (an emitter that cannot be sampled by area) no pixel is flat.
    pub fn flat_pixels(&self, view: &View) -> Vec<bool> {
        let (w, h) = (view.width, view.height);
        let lights = self.lights.as_ref();
        // Per pixel centre: (primitive, back side, visible fraction class) or None.
        let class: Vec<Option<(usize, bool, u8)>> = (0..w * h)
            .into_par_iter()
            .map(|i| {
                let (lights, cdf) = lights?;
                let tot = *cdf.last()?;
                let ray = view.ray((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                let hit = self.accel.closest_hit(&ray, 0.0, f64::INFINITY)?;
                let (_, m, n) = self.side_of(&hit)?;
                if max3(m.e) > 0.0 {
                    return None;
                }
                let mut seen = 0u32;
                let mut tried = 0u32;
                let mut rng = rng_for(0xF1A7, 0, 0);
                for k in 0..16 {
                    let u = (k as f64 + 0.5) / 16.0 * tot;
                    let j = cdf.partition_point(|&c| c <= u).min(lights.len() - 1);
                    let (pk, back, _) = lights[j];
                    let Ok((y, ny)) = self.sample_prim(pk, &mut rng) else {
                        continue;
                    };
                    let ny = if back { -ny } else { ny };
                    let d = y - hit.point;
                    if n.dot(d) <= 0.0 || ny.dot(d) >= 0.0 {
                        tried += 1;
                        continue;
                    }
                    tried += 1;
                    if !self
                        .accel
                        .occluded(hit.point, y, [Some(hit.prim), Some(pk as u32)])
                    {
                        seen += 1;
                    }
                }
                let cls = match seen {
                    0 => 0,
                    x if x == tried => 2,
                    _ => 1,
                };
                Some((hit.prim as usize, !hit.front, cls))
            })
            .collect();
        (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                if x < 2 || y < 2 || x + 2 >= w || y + 2 >= h {
                    return false;
                }
                let Some(c) = class[i] else { return false };
                if c.2 == 1 {
                    return false;
                }
                (y - 2..=y + 2).all(|yy| (x - 2..=x + 2).all(|xx| class[yy * w + xx] == Some(c)))
            })
            .collect()
    }

    /// Radiosity at every texel of `grid` (built from the same scene) from `paths`
    /// walks each, with standard errors; texel `i` draws from its own stream
    /// `(seed, i)`, so the result does not depend on the thread count.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for zero paths or a texel that does not belong to this
    /// scene (surface, side or primitive out of range).
    pub fn texels(
        &self,
        grid: &TexelGrid,
        paths: u64,
        opts: &ReferenceOptions,
    ) -> Result<Vec<SurfaceEstimate>, RenderError> {
        if paths == 0 {
            return Err(invalid("paths", "must be >= 1"));
        }
        grid.texels
            .par_iter()
            .enumerate()
            .map(|(i, t)| {
                let m = self
                    .sides
                    .get(t.surface)
                    .and_then(|s| s[usize::from(t.back)])
                    .filter(|_| (t.prim as usize) < self.prim_surface.len())
                    .ok_or_else(|| invalid("texel", format!("texel {i} is not of this scene")))?;
                let (x, n) = (DVec3::from_array(t.point), DVec3::from_array(t.normal));
                let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
                for k in 0..paths {
                    let mut rng = rng_for(opts.seed, i as u64 | (1 << 40), k);
                    let b = self.radiosity_sample(x, n, Some(t.prim), m, opts, &mut rng);
                    for c in 0..3 {
                        s[c] += b[c];
                        s2[c] += b[c] * b[c];
                    }
                }
                Ok(estimate(s, s2, paths))
            })
            .collect()
    }

    /// Renders `view` with `spp²` stratified samples per pixel, one walk each (pixel
    /// value `B/π`); `progress` is called once per finished row.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for `spp ∉ 1..=256`.
    pub fn render(
        &self,
        view: &View,
        spp: usize,
        opts: &ReferenceOptions,
        progress: &(dyn Fn(u64) + Sync),
    ) -> Result<Image, RenderError> {
        if !(1..=256).contains(&spp) {
            return Err(invalid("spp", format!("{spp} not in 1..=256")));
        }
        let (w, h) = (view.width, view.height);
        let rows: Vec<Vec<[f64; 3]>> = (0..h)
            .into_par_iter()
            .map(|y| {
                let mut row = vec![[0.0; 3]; w];
                for (x, px) in row.iter_mut().enumerate() {
                    let mut rng = rng_for(opts.seed, (y * w + x) as u64, 1);
                    let mut acc = [0.0; 3];
                    for sy in 0..spp {
                        for sx in 0..spp {
                            let jx = (sx as f64 + rng.random::<f64>()) / spp as f64;
                            let jy = (sy as f64 + rng.random::<f64>()) / spp as f64;
                            let ray = view.ray(x as f64 + jx, y as f64 + jy);
                            let Some(hit) = self.accel.closest_hit(&ray, 0.0, f64::INFINITY) else {
                                continue;
                            };
                            let Some((_, m, n)) = self.side_of(&hit) else {
                                continue;
                            };
                            let b = self.radiosity_sample(
                                hit.point,
                                n,
                                Some(hit.prim),
                                m,
                                opts,
                                &mut rng,
                            );
                            for c in 0..3 {
                                acc[c] += b[c];
                            }
                        }
                    }
                    let k = 1.0 / (std::f64::consts::PI * (spp * spp) as f64);
                    *px = acc.map(|v| v * k);
                }
                progress(1);
                row
            })
            .collect();
        let mut img = Image::new(w, h);
        for (y, r) in rows.into_iter().enumerate() {
            img.pixels[y * w..(y + 1) * w].copy_from_slice(&r);
        }
        Ok(img)
    }
}

fn estimate(s: [f64; 3], s2: [f64; 3], n: u64) -> SurfaceEstimate {
    let nf = n as f64;
    let mean = s.map(|v| v / nf);
    let std_error = std::array::from_fn(|c| {
        if n < 2 {
            return f64::INFINITY;
        }
        let var = ((s2[c] - nf * mean[c] * mean[c]) / (nf - 1.0)).max(0.0);
        (var / nf).sqrt()
    });
    SurfaceEstimate {
        mean,
        std_error,
        samples: n,
    }
}
