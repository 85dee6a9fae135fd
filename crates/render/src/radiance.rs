//! Radiance fields: what the renderer evaluates at a ray hit when the exitant light
//! depends on direction (Glossy §3.3, §5.5).
//!
//! [`RadianceField`] gives the radiance `L(x, ω)` (W/(m²·sr), RGB) leaving a hit
//! toward the viewer. Its implementations:
//! - [`Diffuse`]: any [`RadiosityField`] as radiance `B/π` (Lambertian surfaces);
//! - [`GlossyField`]: a `wavelux_glossy::GlossySolution`, evaluated directly (the
//!   reflected 4D Haar expansion plus the exact emission) or by one of its final
//!   gathers (§5.5: from all senders, from the linked ones, from the root links);
//! - [`crate::reference::glossy::TracedRadiance`]: the glossy path tracer, one path
//!   per pixel sample.
//!
//! [`render_radiance`] makes an image of any of them with `spp²` jittered samples per
//! pixel and a per-pixel random stream (bitwise identical for any thread count).
//! Hits on the black back of a one-sided surface show
//! [`RadianceOptions::back_face`] (grey by default in the CLI, black for
//! measurements).

use glam::DVec3;
use rand::RngExt;
use rand_pcg::Pcg64;
use rayon::prelude::*;
use wavelux_geometry::{Accel, Hit};
use wavelux_glossy::{GatherMode, GlossySolution};

use crate::camera::View;
use crate::field::RadiosityField;
use crate::image::Image;
use crate::sampling::rng_for;
use crate::{RenderError, invalid};

/// Anything that gives the radiance leaving a surface toward a direction.
pub trait RadianceField: Sync {
    /// The accelerator primary rays are traced against.
    fn accel(&self) -> &Accel;
    /// Radiance (W/(m²·sr), RGB) leaving `hit` toward the unit world direction `wo`
    /// (the reverse of the primary ray); `None` for the black back of a one-sided
    /// surface or a primitive the field does not know. Stochastic fields draw from
    /// `rng` (one estimate per call).
    fn radiance(&self, hit: &Hit, wo: DVec3, rng: &mut Pcg64) -> Option<[f64; 3]>;
}

/// A [`RadiosityField`] seen as radiance `B/π` (every side Lambertian).
#[derive(Debug)]
pub struct Diffuse<'a, F: ?Sized>(pub &'a F);

impl<F: RadiosityField + ?Sized> RadianceField for Diffuse<'_, F> {
    fn accel(&self) -> &Accel {
        self.0.accel()
    }

    fn radiance(&self, hit: &Hit, _wo: DVec3, _rng: &mut Pcg64) -> Option<[f64; 3]> {
        let p = self.0.resolve(hit)?;
        Some(
            self.0
                .radiosity(&p)
                .map(|b| b * std::f64::consts::FRAC_1_PI),
        )
    }
}

/// A glossy solution as a [`RadianceField`].
#[derive(Debug, Clone, Copy)]
pub struct GlossyField<'a> {
    /// The solution.
    pub solution: &'a GlossySolution,
    /// `None`: the reflected expansion plus exact emission
    /// ([`GlossySolution::radiance_exact_emission`]); `Some((mode, rays))`: the final
    /// gather ([`GlossySolution::gather`]) with `rays` rays per sending node.
    pub gather: Option<(GatherMode, usize)>,
}

impl RadianceField for GlossyField<'_> {
    fn accel(&self) -> &Accel {
        &self.solution.scene.accel
    }

    fn radiance(&self, hit: &Hit, wo: DVec3, rng: &mut Pcg64) -> Option<[f64; 3]> {
        let (p, st) = self.solution.scene.resolve(hit)?;
        Some(match self.gather {
            None => self.solution.radiance_exact_emission(p, st, wo),
            Some((mode, rays)) => self.solution.gather(p, st, wo, mode, rays, rng, true),
        })
    }
}

/// Options of [`render_radiance`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RadianceOptions {
    /// Samples per pixel along each axis (`spp²` jittered samples; `1..=64`).
    pub spp: usize,
    /// Seed of the jitter and of the field's own sampling.
    pub seed: u64,
    /// Radiance shown where a primary ray hits a black back side (W/(m²·sr), RGB).
    pub back_face: [f64; 3],
}

impl Default for RadianceOptions {
    /// 2 × 2 samples per pixel, seed 0, black back faces.
    fn default() -> Self {
        Self {
            spp: 2,
            seed: 0,
            back_face: [0.0; 3],
        }
    }
}

/// Renders `view` of a radiance field (pixel value: the mean radiance of its samples);
/// `progress` is called once per finished row.
///
/// # Errors
/// [`RenderError::Invalid`] for `spp ∉ 1..=64` or a non-finite back-face colour.
pub fn render_radiance<F: RadianceField + ?Sized>(
    field: &F,
    view: &View,
    opts: &RadianceOptions,
    progress: &(dyn Fn(u64) + Sync),
) -> Result<Image, RenderError> {
    if !(1..=64).contains(&opts.spp) {
        return Err(invalid("spp", format!("{} not in 1..=64", opts.spp)));
    }
    if !opts.back_face.iter().all(|v| v.is_finite()) {
        return Err(invalid("back_face", "not finite"));
    }
    let (w, h, n) = (view.width, view.height, opts.spp);
    let rows: Vec<Vec<[f64; 3]>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = (0..w)
                .map(|x| {
                    let mut rng = rng_for(opts.seed, (y * w + x) as u64, 2);
                    let mut acc = [0.0; 3];
                    for sy in 0..n {
                        for sx in 0..n {
                            let jx = (sx as f64 + rng.random::<f64>()) / n as f64;
                            let jy = (sy as f64 + rng.random::<f64>()) / n as f64;
                            let ray = view.ray(x as f64 + jx, y as f64 + jy);
                            let Some(hit) = field.accel().closest_hit(&ray, 0.0, f64::INFINITY)
                            else {
                                continue;
                            };
                            let l = field
                                .radiance(&hit, -ray.dir, &mut rng)
                                .unwrap_or(opts.back_face);
                            for c in 0..3 {
                                acc[c] += l[c];
                            }
                        }
                    }
                    acc.map(|v| v / (n * n) as f64)
                })
                .collect();
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
