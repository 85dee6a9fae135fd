//! A Monte Carlo path tracer for glossy scenes (Ward BRDFs, cosine-power emitters):
//! the ground truth of `wavelux-glossy` (Glossy §6.2–§6.3).
//!
//! It estimates the radiance `L(y, ω)` leaving a surface point by the rendering
//! equation `L = L_e + ∫ f_r(ω_i, ω) L(ω_i) cos θ_i dω_i` with one path per sample:
//! - at every vertex a **light sample** (next-event estimation): a point drawn
//!   uniformly by real area over all emitting sides (per-point pdf
//!   `A_i / (A_tot · P_i · J(s, t))` for a support of parameter-square area `A_i`,
//!   real fraction `P_i` and area element `J`; `1/A_tot` on equal-area maps), its
//!   emitted radiance toward the vertex (Lambertian `E/π` or cosine power
//!   `E (n + 2) cosⁿθ / (2π)`), a shadow ray;
//! - a **BRDF sample** ([`wavelux_glossy::Brdf::sample`]: Ward's half-vector sampling
//!   with its exact pdf or a cosine direction, chosen by `ρ_s : ρ_d`), whose hit adds
//!   the emission it finds;
//! - the two are combined by the balance heuristic (Veach's multiple importance
//!   sampling), so small lights and sharp lobes (`α = 0.01`) both stay bounded;
//! - Russian roulette after `rr_depth` bounces with survival `min(0.95, max throughput)`.
//!
//! The scene is read through [`wavelux_glossy::GlossyScene`]: exact geometry (the
//! supports' maps and masks, one BVH over the real surfaces), each side's Ward BRDF
//! with textures looked up per point, its emitter and its shading frame (Ward's `α_x`
//! along the surface's `tangent` or the support's `∂/∂s`). Those are the scene's
//! *definition*, shared with the solver on purpose; nothing of the solver's
//! discretisation (trees, links, coefficients, projected emission) is used, so the
//! tracer is an independent estimate of the same equation. Rays that escape or hit
//! the black back of a one-sided surface end the path; the eye patch of an importance
//! camera is transparent and black.
//!
//! Determinism: every estimate draws from streams derived from `(seed, key, index)`
//! and sums are reduced in a fixed order, so results are bitwise identical for any
//! number of threads.

use glam::{DVec2, DVec3};
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use wavelux_geometry::{Accel, Hit, Ray};
use wavelux_glossy::GlossyScene;
use wavelux_glossy::ward::cosine_local;
use wavelux_support::Side;

use super::{ReferenceOptions, SurfaceEstimate, estimate};
use crate::radiance::RadianceField;
use crate::render::SECONDARY_EPS_REL;
use crate::sampling::rng_for;
use crate::{RenderError, invalid};

/// Rejection tries for a real point on a masked emitter before the sample is lost.
const REAL_TRIES: usize = 4096;

/// The glossy path tracer over a prepared glossy scene (module docs).
#[derive(Debug)]
pub struct GlossyTracer<'a> {
    scene: &'a GlossyScene,
    /// Emitting patches, cumulative real area, and per patch `A_i / P_i`.
    lights: Vec<(usize, f64)>,
    cdf: Vec<f64>,
    eps: f64,
}

/// A point drawn on an emitter: patch, `(s, t)`, position, unit normal, area pdf.
struct LightPoint {
    patch: usize,
    st: DVec2,
    point: DVec3,
    normal: DVec3,
    pdf_area: f64,
}

fn max3(v: [f64; 3]) -> f64 {
    v[0].max(v[1]).max(v[2])
}

impl<'a> GlossyTracer<'a> {
    /// A tracer over `scene` (every emitting side is light-sampled).
    #[must_use]
    pub fn new(scene: &'a GlossyScene) -> Self {
        let mut lights = Vec::new();
        let mut cdf = Vec::new();
        let mut tot = 0.0;
        for (i, p) in scene.patches.iter().enumerate() {
            if !p.is_emitter() || p.is_eye() {
                continue;
            }
            let real = p.support.real_area();
            let frac = p.support.real_fraction(0.0, 0.0, 1.0);
            if !(real > 0.0 && frac > 0.0) {
                continue;
            }
            tot += real;
            lights.push((i, p.support.area / frac));
            cdf.push(tot);
        }
        Self {
            scene,
            lights,
            cdf,
            eps: SECONDARY_EPS_REL * scene.diagonal,
        }
    }

    /// The prepared scene.
    #[must_use]
    pub fn scene(&self) -> &GlossyScene {
        self.scene
    }

    /// Total real area of the emitting sides (m²).
    fn light_area(&self) -> f64 {
        self.cdf.last().copied().unwrap_or(0.0)
    }

    /// Area density of [`Self::sample_light`] at `(patch, st)` (0 for a non-emitter).
    fn light_pdf(&self, patch: usize, st: DVec2) -> f64 {
        let Some(&(_, scale)) = self.lights.iter().find(|(i, _)| *i == patch) else {
            return 0.0;
        };
        let j = self.scene.patches[patch].support.jacobian(st.x, st.y);
        if j > 0.0 {
            scale / (self.light_area() * j)
        } else {
            0.0
        }
    }

    fn sample_light(&self, rng: &mut Pcg64) -> Option<LightPoint> {
        let tot = self.light_area();
        if tot <= 0.0 {
            return None;
        }
        let u = rng.random::<f64>() * tot;
        let j = self
            .cdf
            .partition_point(|&c| c <= u)
            .min(self.lights.len() - 1);
        let patch = self.lights[j].0;
        let sup = &self.scene.patches[patch].support;
        for _ in 0..REAL_TRIES {
            let st = DVec2::new(rng.random(), rng.random());
            if sup.is_real(st.x, st.y) {
                let (point, normal) = sup.point_normal(st.x, st.y);
                return Some(LightPoint {
                    patch,
                    st,
                    point,
                    normal,
                    pdf_area: self.light_pdf(patch, st),
                });
            }
        }
        None
    }

    /// Emitted radiance of `patch` at `st` toward the world direction `w`.
    fn emitted(&self, patch: usize, st: DVec2, w: DVec3) -> [f64; 3] {
        let f = self.scene.patches[patch].frame(st.x, st.y);
        self.scene.emitted(patch, st.x, st.y, f.to_local(w))
    }

    /// One-sample estimate of the radiance leaving `(patch, st)` toward the unit world
    /// direction `w` (W/(m²·sr), RGB); `emitted`: include the point's own emission.
    fn sample(
        &self,
        patch: usize,
        st: DVec2,
        w: DVec3,
        emitted: bool,
        opts: &ReferenceOptions,
        rng: &mut Pcg64,
    ) -> [f64; 3] {
        let mut out = if emitted {
            self.emitted(patch, st, w)
        } else {
            [0.0; 3]
        };
        let mut thr = [1.0; 3];
        let (mut p, mut st, mut wo) = (patch, st, w);
        for depth in 0..opts.max_depth {
            let q = &self.scene.patches[p];
            let brdf = self.scene.brdf_at(p, st.x, st.y);
            let frame = q.frame(st.x, st.y);
            let wo_l = frame.to_local(wo);
            if brdf.is_black() || wo_l.z <= 0.0 {
                break;
            }
            let x = q.support.visibility_point(st.x, st.y);
            // Light sample (balance heuristic against the BRDF sample).
            if let Some(l) = self.sample_light(rng) {
                let d = l.point - x;
                let r2 = d.length_squared();
                let wi = d / r2.sqrt();
                let (cx, cy) = (frame.n.dot(wi), -l.normal.dot(wi));
                if r2 > 0.0
                    && cx > 0.0
                    && cy > 0.0
                    && l.pdf_area > 0.0
                    && l.patch != p
                    && !self.scene.accel.occluded(
                        x,
                        self.scene.patches[l.patch]
                            .support
                            .visibility_point(l.st.x, l.st.y),
                        [q.prim, self.scene.patches[l.patch].prim],
                    )
                {
                    let le = self.emitted(l.patch, l.st, -wi);
                    let wi_l = frame.to_local(wi);
                    let f = brdf.eval(wi_l, wo_l);
                    let pl = l.pdf_area * r2 / cy;
                    let pb = brdf.pdf(wo_l, wi_l);
                    let k = cx / (pl + pb);
                    for c in 0..3 {
                        out[c] += thr[c] * f[c] * le[c] * k;
                    }
                }
            }
            // BRDF sample (reciprocal: the incoming direction drawn given the outgoing).
            let Some(bs) = brdf.sample(wo_l, rng.random()) else {
                break;
            };
            let wi = frame.to_world(bs.wo);
            let ray = Ray {
                origin: x + frame.n * self.eps,
                dir: wi,
            };
            let Some(hit) = self.scene.accel.closest_hit(&ray, self.eps, f64::INFINITY) else {
                break;
            };
            let Some((np, nst)) = self.scene.resolve(&hit) else {
                break;
            };
            let le = self.emitted(np, nst, -wi);
            if max3(le) > 0.0 {
                let ny = self.scene.patches[np].support.normal_at(nst.x, nst.y);
                let cy = (-ny.dot(wi)).max(1e-300);
                let pl = self.light_pdf(np, nst) * hit.t * hit.t / cy;
                let wgt = bs.pdf / (bs.pdf + pl);
                for c in 0..3 {
                    out[c] += thr[c] * bs.weight[c] * le[c] * wgt;
                }
            }
            for c in 0..3 {
                thr[c] *= bs.weight[c];
            }
            if depth + 1 >= opts.rr_depth {
                let s = max3(thr).min(0.95);
                if s <= 0.0 || rng.random::<f64>() >= s {
                    break;
                }
                thr = thr.map(|t| t / s);
            } else if max3(thr) <= 0.0 {
                break;
            }
            (p, st, wo) = (np, nst, -wi);
        }
        out
    }

    /// The radiance `L(y, ω)` (W/(m²·sr), RGB, emission included) leaving the point
    /// `(s, t)` of `patch` toward the world direction `w`, from `paths` paths; `key`
    /// selects the random streams.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for a bad patch, zero paths, `(s, t)` outside the unit
    /// square or a direction that is not finite and non-zero.
    pub fn radiance_at(
        &self,
        patch: usize,
        st: DVec2,
        w: DVec3,
        paths: u64,
        key: u64,
        opts: &ReferenceOptions,
    ) -> Result<SurfaceEstimate, RenderError> {
        if patch >= self.scene.patches.len() {
            return Err(invalid("patch", format!("{patch} out of range")));
        }
        if paths == 0 {
            return Err(invalid("paths", "must be >= 1"));
        }
        if !((0.0..=1.0).contains(&st.x) && (0.0..=1.0).contains(&st.y)) {
            return Err(invalid("st", format!("{st} outside [0, 1]²")));
        }
        let w = w
            .try_normalize()
            .ok_or_else(|| invalid("direction", format!("{w} is not finite and non-zero")))?;
        let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
        for i in 0..paths {
            let mut rng = rng_for(opts.seed, key | (1 << 61), i);
            let l = self.sample(patch, st, w, true, opts, &mut rng);
            for c in 0..3 {
                s[c] += l[c];
                s2[c] += l[c] * l[c];
            }
        }
        Ok(estimate(s, s2, paths))
    }

    /// Mean radiant exitance `M = (1/A) ∫∫ L cos θ dω dA` (W/m², RGB, emission
    /// included) of one side of a scene surface: `samples` points uniform by real
    /// area over the side's patches, one cosine-distributed direction and one path
    /// each (`M` is estimated by `π L`). This is the quantity
    /// [`wavelux_glossy::GlossySolution::side_exitance`] reports.
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for zero samples or a side without patches.
    pub fn side_exitance(
        &self,
        surface: usize,
        side: Side,
        samples: u64,
        opts: &ReferenceOptions,
    ) -> Result<SurfaceEstimate, RenderError> {
        if samples == 0 {
            return Err(invalid("samples", "must be >= 1"));
        }
        let mut parts = Vec::new();
        let mut cdf = Vec::new();
        let mut tot = 0.0;
        for (i, p) in self.scene.patches.iter().enumerate() {
            if p.surface == surface && p.side == side && !p.is_eye() {
                let a = p.support.real_area();
                if a > 0.0 {
                    tot += a;
                    parts.push(i);
                    cdf.push(tot);
                }
            }
        }
        if parts.is_empty() {
            return Err(invalid(
                "side",
                format!("surface {surface} has no lit {side:?} side"),
            ));
        }
        let stream = surface as u64 | (u64::from(side == Side::Back) << 48) | (1 << 60);
        const CHUNK: u64 = 256;
        let sums: Vec<([f64; 3], [f64; 3])> = (0..samples.div_ceil(CHUNK))
            .into_par_iter()
            .map(|ch| {
                let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
                for i in ch * CHUNK..((ch + 1) * CHUNK).min(samples) {
                    let mut rng = rng_for(opts.seed, stream, i);
                    let m = self.exitance_sample(&parts, &cdf, tot, opts, &mut rng);
                    for c in 0..3 {
                        s[c] += m[c];
                        s2[c] += m[c] * m[c];
                    }
                }
                (s, s2)
            })
            .collect();
        let (mut s, mut s2) = ([0.0; 3], [0.0; 3]);
        for (a, b) in sums {
            for c in 0..3 {
                s[c] += a[c];
                s2[c] += b[c];
            }
        }
        Ok(estimate(s, s2, samples))
    }

    /// One sample of `π L` at a point uniform by real area and a cosine direction.
    fn exitance_sample(
        &self,
        parts: &[usize],
        cdf: &[f64],
        tot: f64,
        opts: &ReferenceOptions,
        rng: &mut Pcg64,
    ) -> [f64; 3] {
        let u = rng.random::<f64>() * tot;
        let j = cdf.partition_point(|&c| c <= u).min(parts.len() - 1);
        let patch = parts[j];
        let sup = &self.scene.patches[patch].support;
        // Uniform by area: uniform (s, t) on the real part, accepted with probability
        // J / max J on maps that are not equal-area (here J is sampled on a grid bound).
        for _ in 0..REAL_TRIES {
            let st = DVec2::new(rng.random(), rng.random());
            if !sup.is_real(st.x, st.y) {
                continue;
            }
            if !sup.is_equal_area() {
                let jm = self.jacobian_bound(patch);
                if rng.random::<f64>() * jm > sup.jacobian(st.x, st.y) {
                    continue;
                }
            }
            let f = self.scene.patches[patch].frame(st.x, st.y);
            let w = f.to_world(cosine_local(rng.random()));
            let l = self.sample(patch, st, w, true, opts, rng);
            return l.map(|v| v * std::f64::consts::PI);
        }
        [0.0; 3]
    }

    /// An upper bound of the area element of a non-equal-area support: the maximum on
    /// a 33 × 33 grid times 1.5.
    fn jacobian_bound(&self, patch: usize) -> f64 {
        let sup = &self.scene.patches[patch].support;
        let mut m: f64 = 0.0;
        for i in 0..=32 {
            for k in 0..=32 {
                m = m.max(sup.jacobian(f64::from(i) / 32.0, f64::from(k) / 32.0));
            }
        }
        1.5 * m
    }
}

/// A [`GlossyTracer`] as a [`RadianceField`]: one path per pixel sample with these
/// walk options (the pixel's stream replaces `opts.seed`).
#[derive(Debug, Clone, Copy)]
pub struct TracedRadiance<'t, 'a> {
    /// The tracer.
    pub tracer: &'t GlossyTracer<'a>,
    /// Roulette depth and path cap.
    pub opts: ReferenceOptions,
}

impl RadianceField for TracedRadiance<'_, '_> {
    fn accel(&self) -> &Accel {
        &self.tracer.scene.accel
    }

    fn radiance(&self, hit: &Hit, wo: DVec3, rng: &mut Pcg64) -> Option<[f64; 3]> {
        let (p, st) = self.tracer.scene.resolve(hit)?;
        Some(self.tracer.sample(p, st, wo, true, &self.opts, rng))
    }
}
