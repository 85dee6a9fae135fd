//! Shared pieces of the meshless reproductions (Meshless §2.3, §3, §4.2): the test
//! points seen by a scene's camera, the independent path-traced indirect irradiance at
//! them (`wavelux_render::PathTracer::indirect_irradiance_at`), the relative L1 error
//! with the reference's own noise floor, a precomputation with the CPU time of its
//! phases, and a relit frame with the CPU time of its phases ([`crate::cpu`]).
//!
//! The error measure (issue 15, "Ground truth"): indirect scalar irradiance `n·i`
//! (W/m², RGB) at points of the camera's view, `Σ_p Σ_c |ours − ref| / Σ_p Σ_c |ref|`.
//! The reference is a Monte Carlo estimate; its noise adds to that sum, so every error
//! comes with the floor `Σ √(2/π)·σ / Σ |ref|` (the expected `|noise|` of a Gaussian
//! estimate with standard error `σ`), reported next to it.

use crate::cpu::{Elapsed, Stopwatch};
use anyhow::Context;
use rayon::prelude::*;
use std::sync::Mutex;
use wavelux::meshless::{
    CpuBackend, DirectLighting, Indirect, MeshlessConfig, Precomputed, Relighter, SceneSurfaces,
    SurfaceQuery,
};
use wavelux::param::glam::DVec3;
use wavelux::render::{Image, PathTracer, ReferenceOptions, View};
use wavelux::scene::builtin::builtin;
use wavelux::scene::{Light, Scene};

/// A point of the camera's view: position and the unit normal of the side seen.
pub type ViewPoint = (DVec3, DVec3);

/// A built-in scene by name.
pub fn scene(name: &str) -> anyhow::Result<Scene> {
    builtin(name).with_context(|| format!("built-in scene {name} missing"))
}

/// Test points on a camera grid: the points, the pixel `(x, y)` of each, and the
/// grid's width and height.
pub struct Grid {
    /// Points, in scan order.
    pub points: Vec<ViewPoint>,
    /// The pixel of each point.
    pub pixels: Vec<(usize, usize)>,
    /// Grid width.
    pub width: usize,
    /// Grid height.
    pub height: usize,
}

impl Grid {
    /// An image of per-point values on the grid (black where no point).
    pub fn image(&self, values: &[[f64; 3]]) -> Image {
        let mut img = Image::new(self.width, self.height);
        for (&(x, y), v) in self.pixels.iter().zip(values) {
            img.pixels[y * self.width + x] = *v;
        }
        img
    }
}

/// Up to `n` points where the rays through a regular grid of the scene's first
/// camera's pixels (16:9, pixel centres) hit a reflecting side, in scan order.
pub fn visible_points(
    scene: &Scene,
    query: &SceneSurfaces,
    n: usize,
) -> anyhow::Result<Vec<ViewPoint>> {
    Ok(view_grid(scene, query, n)?.points)
}

/// [`visible_points`] with their pixels.
pub fn view_grid(scene: &Scene, query: &SceneSurfaces, n: usize) -> anyhow::Result<Grid> {
    let cam = scene
        .cameras
        .first()
        .with_context(|| format!("scene {} has no camera", scene.name))?;
    // A grid with ~1.3 n cells: some rays miss or hit black sides.
    let h = ((1.3 * n as f64 * 9.0 / 16.0).sqrt().ceil() as usize).max(1);
    let w = (h * 16).div_ceil(9);
    let view = View::new(cam, w, h)?;
    let mut out = Vec::with_capacity(n);
    let mut pixels = Vec::with_capacity(n);
    'grid: for y in 0..h {
        for x in 0..w {
            let ray = view.ray(x as f64 + 0.5, y as f64 + 0.5);
            if let Some(hit) = query.closest_hit(ray.origin, ray.dir)
                && hit.reflectance.is_some_and(|r| r.iter().any(|&c| c > 0.0))
            {
                out.push((hit.point, hit.normal));
                pixels.push((x, y));
                if out.len() == n {
                    break 'grid;
                }
            }
        }
    }
    anyhow::ensure!(
        out.len() >= n / 2,
        "only {} of {n} camera rays hit a reflecting side in {}",
        out.len(),
        scene.name
    );
    Ok(Grid {
        points: out,
        pixels,
        width: w,
        height: h,
    })
}

/// The path-traced indirect irradiance (W/m², RGB) at each point: mean and standard
/// error from `paths` walks per point (point `k` uses random stream `k`).
pub fn reference_indirect(
    tracer: &PathTracer,
    points: &[ViewPoint],
    paths: u64,
    seed: u64,
) -> anyhow::Result<Vec<([f64; 3], [f64; 3])>> {
    let opts = ReferenceOptions {
        seed,
        ..ReferenceOptions::default()
    };
    points
        .par_iter()
        .enumerate()
        .map(|(k, &(x, n))| {
            let e = tracer.indirect_irradiance_at(x, n, paths, k as u64, &opts)?;
            Ok((e.mean, e.std_error))
        })
        .collect()
}

/// Relative L1 error of `ours` against the reference and the reference's noise floor
/// (module docs).
pub fn relative_l1(ours: &[[f64; 3]], reference: &[([f64; 3], [f64; 3])]) -> (f64, f64) {
    let k = (2.0 / std::f64::consts::PI).sqrt();
    let (mut diff, mut norm, mut floor) = (0.0, 0.0, 0.0);
    for (o, (r, s)) in ours.iter().zip(reference) {
        for c in 0..3 {
            diff += (o[c] - r[c]).abs();
            norm += r[c].abs();
            floor += k * s[c];
        }
    }
    (diff / norm, floor / norm)
}

/// Mean of all channels of ours over the mean of the reference's (energy kept).
pub fn energy_ratio(ours: &[[f64; 3]], reference: &[([f64; 3], [f64; 3])]) -> f64 {
    let o: f64 = ours.iter().flatten().sum();
    let r: f64 = reference.iter().flat_map(|(m, _)| m.iter()).sum();
    o / r
}

/// Ours at the points.
pub fn at_points(ind: &Indirect<'_>, points: &[ViewPoint]) -> Vec<[f64; 3]> {
    ind.bake(points)
}

/// The direct lighting of a scene: its punctual lights plus its area emitters (by
/// next-event estimation with `emitter_samples` samples per point).
pub fn scene_direct(
    scene: &Scene,
    query: &SceneSurfaces,
    emitter_samples: usize,
    seed: u64,
) -> DirectLighting {
    let mut parts = Vec::new();
    if !scene.lights.is_empty() {
        parts.push(DirectLighting::Lights(scene.lights.clone()));
    }
    if query.has_emitters() {
        parts.push(DirectLighting::Emitters {
            samples: emitter_samples,
            seed,
        });
    }
    DirectLighting::Sum(parts)
}

/// A scene with its punctual lights replaced by `lights`.
pub fn with_lights(scene: &Scene, lights: &[Light]) -> Scene {
    let mut s = scene.clone();
    s.lights = lights.to_vec();
    s
}

/// The time of one precomputation: the whole call (wall and CPU) and the CPU seconds
/// of its phases, read at the crate's progress calls. Placement ends at the last
/// "points" call; the refinement (which includes building the basis's DAG, done
/// between the two) ends at the first "bounces" call; the bounces at the last one.
/// Without a CPU clock the phases are wall seconds ([`Elapsed::cpu_or_wall`]).
#[derive(Debug, Clone, Copy)]
pub struct PrecomputeTime {
    /// The whole call.
    pub total: Elapsed,
    /// Point placement (CPU s).
    pub placement: f64,
    /// Refinement of `T` (CPU s).
    pub refine: f64,
    /// The bounce products (CPU s).
    pub bounces: f64,
}

/// Precomputes and times the call and its phases ([`PrecomputeTime`]).
pub fn precompute(
    scene: &Scene,
    cfg: &MeshlessConfig,
) -> anyhow::Result<(Precomputed, PrecomputeTime)> {
    let watch = Stopwatch::start();
    let marks: Mutex<Vec<(String, usize, f64)>> = Mutex::new(Vec::new());
    let pre = Precomputed::build(scene, cfg, &|phase, done, _| {
        let t = watch.elapsed().cpu_or_wall();
        if let Ok(mut m) = marks.lock() {
            m.push((phase.to_string(), done, t));
        }
    })
    .with_context(|| format!("meshless precomputation of {}", scene.name))?;
    let total = watch.elapsed();
    let marks = marks.into_inner().unwrap_or_default();
    let at = |phase: &str, first: bool| {
        let mut hits = marks.iter().filter(|m| m.0 == phase).map(|m| m.2);
        if first { hits.next() } else { hits.next_back() }
    };
    let placed = at("points", false).unwrap_or(0.0);
    let refined = at("bounces", true).unwrap_or(placed);
    let bounced = at("bounces", false).unwrap_or(refined);
    Ok((
        pre,
        PrecomputeTime {
            total,
            placement: placed,
            refine: refined - placed,
            bounces: bounced - refined,
        },
    ))
}

/// The CPU time (ms) of one relit frame's phases: the direct irradiance at the sender
/// points by shadow rays, then `relight_direct` (pull-push, skip and `S·e`). The
/// crate's own wall-time split of the second stays in the frame's `Indirect::times`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameCpu {
    /// Direct irradiance at the sender points (CPU ms).
    pub direct_ms: f64,
    /// Pull-push, skip and `S·e` (CPU ms).
    pub transport_ms: f64,
}

impl FrameCpu {
    /// Direct + pull-push + `S·e` (CPU ms).
    pub fn total_ms(&self) -> f64 {
        self.direct_ms + self.transport_ms
    }
}

/// Relights `pre` with punctual `lights` (the phases of `Relighter::relight`, timed
/// apart in CPU time: [`FrameCpu`]).
pub fn relight_timed<'a>(
    pre: &'a Precomputed,
    relighter: &Relighter<'a, CpuBackend>,
    query: &SceneSurfaces,
    lights: &[Light],
) -> anyhow::Result<(Indirect<'a>, FrameCpu)> {
    let watch = Stopwatch::start();
    let direct = DirectLighting::Lights(lights.to_vec()).irradiance(query, &pre.sender_points())?;
    let direct_ms = 1e3 * watch.elapsed().cpu_or_wall();
    let watch = Stopwatch::start();
    let ind = relighter.relight_direct(&direct)?;
    let transport_ms = 1e3 * watch.elapsed().cpu_or_wall();
    Ok((
        ind,
        FrameCpu {
            direct_ms,
            transport_ms,
        },
    ))
}

/// Total points of a precomputation (receiver functions).
pub fn functions(pre: &Precomputed) -> usize {
    pre.stats.points_per_level.iter().sum()
}

/// Least-squares slope of `log y` against `log x`.
pub fn log_slope(xy: &[(f64, f64)]) -> f64 {
    let n = xy.len() as f64;
    let (mut sx, mut sy, mut sxx, mut sxy) = (0.0, 0.0, 0.0, 0.0);
    for &(x, y) in xy {
        let (a, b) = (x.ln(), y.ln());
        sx += a;
        sy += b;
        sxx += a * a;
        sxy += a * b;
    }
    (n * sxy - sx * sy) / (n * sxx - sx * sx)
}
