//! Images of a [`RadiosityField`]: primary rays through the field's accelerator, the
//! field evaluated at the hit, and an optional one-bounce final gather (Glossy §5.5).
//!
//! Without gather a pixel sample shows `B(x)/π` at its primary hit `x`. With a final
//! gather of `g` rays the radiosity at `x` is re-estimated from the solution one
//! bounce away, `B(x) ≈ E(x) + ρ(x)·(1/g) Σ_k B(y_k)`, with `y_k` the hits of
//! cosine-distributed rays from `x` (pdf `cos θ/π`, so the irradiance estimator is the
//! plain mean of the `B(y_k)`). When the field can sample its emitters
//! ([`RadiosityField::sample_emitter`]), the emitted part of the irradiance is
//! estimated by light sampling as well (one shadow ray per gather ray, combined with
//! the gather rays' hits on emitters by the balance heuristic) and the gather rays
//! otherwise collect the reflected part `B − E`: direct shadows then come from exact
//! visibility per pixel, not from the solution's elements. This replaces the element-wise (blocky) radiosity by a
//! per-pixel integral of it, which sharpens shadows and hides element boundaries
//! (Glossy §5.5 uses the same one-bounce gather for its glossy final pass).
//!
//! Determinism: each pixel has its own random stream derived from `(seed, pixel)`, so
//! images are bitwise identical for any thread count.

use std::sync::atomic::{AtomicU64, Ordering};

use glam::DVec3;
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use serde::Serialize;
use wavelux_geometry::Ray;

use crate::camera::View;
use crate::field::{RadiosityField, SurfacePoint};
use crate::image::Image;
use crate::sampling::{cosine_dir, rng_for};
use crate::{RenderError, invalid};

/// Options of [`render`].
///
/// How a pixel sample at a surface point `x` is shaded:
/// - `gather = 0`, `direct = 0`: the field's radiosity `B(x)` itself;
/// - `gather = 0`, `direct > 0`: `E + ρ·H_d(x) + B_ind(x)`: exact direct light
///   ([`crate::DirectLight`], `direct` stratified shadow rays per emitter) plus the
///   field's indirect part ([`RadiosityField::indirect`]); a field that cannot separate
///   its indirect part is shown as `B(x)` (counted in [`RenderStats::unsplit`]);
/// - `gather > 0`, `direct = 0`: one-bounce final gather with light sampling (module
///   docs);
/// - `gather > 0`, `direct > 0`: exact direct light plus a final gather of the field's
///   reflected radiosity `B − E` for the indirect part.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderOptions {
    /// Samples per pixel along each axis (`spp²` stratified, jittered samples; `1..=64`).
    pub spp: usize,
    /// Final-gather rays per pixel sample (0: off; `≤ 65536`).
    pub gather: usize,
    /// Shadow rays per emitter and pixel sample for exact direct light (0: off;
    /// `≤ 4096`; rounded down to a square on triangles and parallelograms).
    pub direct: usize,
    /// Seed of the jitter, gather directions and light samples.
    pub seed: u64,
}

impl Default for RenderOptions {
    /// 2×2 samples per pixel, no gather, no direct light, seed 0.
    fn default() -> Self {
        Self {
            spp: 2,
            gather: 0,
            direct: 0,
            seed: 0,
        }
    }
}

/// Counts of a render.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct RenderStats {
    /// Primary rays traced.
    pub primary_rays: u64,
    /// Final-gather rays traced (with their light-sampling shadow rays).
    pub gather_rays: u64,
    /// Shadow rays of exact direct light.
    pub direct_rays: u64,
    /// Pixel samples shown as the field's radiosity because it could not separate its
    /// indirect part (with `direct > 0` and `gather = 0`).
    pub unsplit: u64,
}

/// Relative ray-origin offset along the normal and minimum hit distance of secondary
/// rays (times the scene diagonal).
pub(crate) const SECONDARY_EPS_REL: f64 = 1e-7;

/// Traces a secondary ray from a surface point and returns the field's radiosity at
/// its hit (0 if it escapes or hits a black back side).
pub(crate) fn radiosity_along<F: RadiosityField + ?Sized>(
    field: &F,
    origin: DVec3,
    dir: DVec3,
    eps: f64,
) -> [f64; 3] {
    let ray = Ray { origin, dir };
    match field.accel().closest_hit(&ray, eps, f64::INFINITY) {
        Some(h) => field.resolve(&h).map_or([0.0; 3], |p| field.radiosity(&p)),
        None => [0.0; 3],
    }
}

/// Like [`radiosity_along`] but the emitted part of the hit only with its
/// balance-heuristic weight against [`direct_light`] (`normal_cos`: cosine of the ray
/// with the normal at its origin).
pub(crate) fn reflected_along<F: RadiosityField + ?Sized>(
    field: &F,
    origin: DVec3,
    dir: DVec3,
    normal_cos: f64,
    eps: f64,
) -> [f64; 3] {
    let ray = Ray { origin, dir };
    match field.accel().closest_hit(&ray, eps, f64::INFINITY) {
        Some(h) => field.resolve(&h).map_or([0.0; 3], |p| {
            let b = field.radiosity(&p);
            let e = field.emission(&p);
            // The emission's balance-heuristic share (the light sample takes the rest).
            let w = match field.sample_emitter([0.5; 3]) {
                Some(s) if e.iter().any(|&v| v > 0.0) => {
                    let pb = normal_cos / std::f64::consts::PI;
                    let cy = (-dir.dot(p.normal)).max(1e-300);
                    let pl = h.t * h.t / (cy * s.total_area);
                    pb / (pb + pl)
                }
                _ => 0.0,
            };
            std::array::from_fn(|c| b[c] - e[c] + w * e[c])
        }),
        None => [0.0; 3],
    }
}

/// One-sample light-sampling estimate of the emitted irradiance at `x` (normal `n`),
/// balance-heuristic weighted against the gather rays, if the drawn point is visible.
pub(crate) fn direct_light<F: RadiosityField + ?Sized>(
    field: &F,
    x: DVec3,
    n: DVec3,
    u: [f64; 3],
) -> [f64; 3] {
    let Some(s) = field.sample_emitter(u) else {
        return [0.0; 3];
    };
    let d = s.point - x;
    let r2 = d.length_squared();
    if r2 <= 0.0 {
        return [0.0; 3];
    }
    let r = r2.sqrt();
    let (cx, cy) = (n.dot(d) / r, -s.normal.dot(d) / r);
    if cx <= 0.0 || cy <= 0.0 || field.accel().occluded(x, s.point, [None, Some(s.prim)]) {
        return [0.0; 3];
    }
    // Balance heuristic against the cosine-distributed gather rays (solid angle pdfs).
    let pl = r2 / (cy * s.total_area);
    let pb = cx / std::f64::consts::PI;
    let g = cx / std::f64::consts::PI / (pl + pb);
    s.emission.map(|e| e * g)
}

/// The radiosity shown for a pixel sample at `p` (on primitive `prim`), by the modes
/// of [`RenderOptions`]; ray counts go to `counts`.
fn shade<F: RadiosityField + ?Sized>(
    field: &F,
    p: &SurfacePoint,
    prim: u32,
    opts: &RenderOptions,
    eps: f64,
    rng: &mut Pcg64,
    counts: &mut RenderStats,
) -> [f64; 3] {
    if opts.gather == 0 && opts.direct == 0 {
        return field.radiosity(p);
    }
    let e = field.emission(p);
    let rho = field.reflectance(p);
    if !rho.iter().any(|&r| r > 0.0) {
        return e;
    }
    let lights = field.direct_light().filter(|_| opts.direct > 0);
    let direct = match lights {
        Some(l) => {
            let (h, rays) = l.irradiance(
                field.accel(),
                p.point,
                p.normal,
                Some(prim),
                opts.direct,
                rng,
            );
            counts.direct_rays += rays;
            Some(h)
        }
        None => None,
    };
    let o = p.point + p.normal * eps;
    match (direct, opts.gather) {
        (Some(hd), 0) => match field.indirect(p) {
            Some(ind) => std::array::from_fn(|c| e[c] + rho[c] * hd[c] + ind[c]),
            None => {
                counts.unsplit += 1;
                field.radiosity(p)
            }
        },
        (Some(hd), g) => {
            // Exact direct light plus a gather of the reflected radiosity B − E.
            let mut irr = [0.0; 3];
            for _ in 0..g {
                let d = cosine_dir(p.normal, rng.random(), rng.random());
                let ray = Ray { origin: o, dir: d };
                if let Some(h) = field.accel().closest_hit(&ray, eps, f64::INFINITY)
                    && let Some(q) = field.resolve(&h)
                {
                    let (b, ee) = (field.radiosity(&q), field.emission(&q));
                    for c in 0..3 {
                        irr[c] += b[c] - ee[c];
                    }
                }
            }
            counts.gather_rays += g as u64;
            std::array::from_fn(|c| e[c] + rho[c] * (hd[c] + irr[c] / g as f64))
        }
        (None, 0) => field.radiosity(p),
        (None, g) => {
            let mut irr = [0.0; 3];
            let nee = field.sample_emitter([0.5; 3]).is_some();
            for _ in 0..g {
                let d = cosine_dir(p.normal, rng.random(), rng.random());
                let bb = if nee {
                    reflected_along(field, o, d, d.dot(p.normal), eps)
                } else {
                    radiosity_along(field, o, d, eps)
                };
                let dl = if nee {
                    direct_light(
                        field,
                        p.point,
                        p.normal,
                        [rng.random(), rng.random(), rng.random()],
                    )
                } else {
                    [0.0; 3]
                };
                for c in 0..3 {
                    irr[c] += bb[c] + dl[c];
                }
            }
            counts.gather_rays += g as u64 * if nee { 2 } else { 1 };
            std::array::from_fn(|c| e[c] + rho[c] * irr[c] / g as f64)
        }
    }
}

/// Renders `view` of `field`; `progress` is called with the number of rows finished
/// (once per row, from worker threads).
///
/// # Errors
/// [`RenderError::Invalid`] for out-of-range options.
pub fn render<F: RadiosityField + ?Sized>(
    field: &F,
    view: &View,
    opts: &RenderOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<(Image, RenderStats), RenderError> {
    if !(1..=64).contains(&opts.spp) {
        return Err(invalid("spp", format!("{} not in 1..=64", opts.spp)));
    }
    if opts.gather > 65536 {
        return Err(invalid("gather", format!("{} > 65536", opts.gather)));
    }
    if opts.direct > 4096 {
        return Err(invalid("direct", format!("{} > 4096", opts.direct)));
    }
    let (w, h) = (view.width, view.height);
    let diag = field.accel().bounds().diagonal().length();
    let eps = SECONDARY_EPS_REL * if diag.is_finite() { diag } else { 1.0 };
    let primary = AtomicU64::new(0);
    let gathered = AtomicU64::new(0);
    let direct = AtomicU64::new(0);
    let unsplit = AtomicU64::new(0);
    let n = opts.spp;
    let inv_pi = 1.0 / std::f64::consts::PI;
    let rows: Vec<Vec<[f64; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let mut row = vec![[0.0; 3]; w];
            let mut counts = RenderStats::default();
            for (x, px) in row.iter_mut().enumerate() {
                let mut rng = rng_for(opts.seed, (y * w + x) as u64, 0);
                let mut acc = [0.0; 3];
                for sy in 0..n {
                    for sx in 0..n {
                        let jx = (sx as f64 + rng.random::<f64>()) / n as f64;
                        let jy = (sy as f64 + rng.random::<f64>()) / n as f64;
                        let ray = view.ray(x as f64 + jx, y as f64 + jy);
                        let Some(hit) = field.accel().closest_hit(&ray, 0.0, f64::INFINITY) else {
                            continue;
                        };
                        let Some(p) = field.resolve(&hit) else {
                            continue;
                        };
                        let b = shade(field, &p, hit.prim, opts, eps, &mut rng, &mut counts);
                        for c in 0..3 {
                            acc[c] += b[c];
                        }
                    }
                }
                let k = inv_pi / (n * n) as f64;
                *px = acc.map(|v| v * k);
            }
            primary.fetch_add((w * n * n) as u64, Ordering::Relaxed);
            gathered.fetch_add(counts.gather_rays, Ordering::Relaxed);
            direct.fetch_add(counts.direct_rays, Ordering::Relaxed);
            unsplit.fetch_add(counts.unsplit, Ordering::Relaxed);
            progress(1);
            row
        })
        .collect();
    let mut img = Image::new(w, h);
    for (y, r) in rows.into_iter().enumerate() {
        img.pixels[y * w..(y + 1) * w].copy_from_slice(&r);
    }
    Ok((
        img,
        RenderStats {
            primary_rays: primary.into_inner(),
            gather_rays: gathered.into_inner(),
            direct_rays: direct.into_inner(),
            unsplit: unsplit.into_inner(),
        },
    ))
}
