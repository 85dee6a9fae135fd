//! The references of one scene (surface averages, texels, a converged image, each
//! with its noise floor) and the measurement of one run against them: every metric's
//! error and the CPU time it took to get there ([`crate::cpu`]: every thread of this
//! process, or of the Mitsuba process for its rows; wall time where `/proc` is
//! unavailable), so that times of methods measured in one run compare their work and
//! not the machine's load.

use crate::cpu::Stopwatch;

use wavelux::render::{
    Image, PathTracer, ReferenceOptions, RenderOptions, SolutionField, SurfaceEstimate, TexelGrid,
    View, auto_camera, render, scene_up,
};
use wavelux::scene::Scene;
use wavelux::solver::Solution;

/// Number of metrics.
pub const N: usize = 5;
/// Index of the surface-average metric.
pub const SURFACE: usize = 0;
/// Index of the texel metric.
pub const TEXEL: usize = 1;
/// Index of the image metric (the solution itself, no final gather).
pub const IMAGE: usize = 2;
/// Index of the image metric with final gather.
pub const GATHER: usize = 3;
/// Index of the image metric with exact direct light plus the solution's indirect part
/// (the command's default image).
pub const DIRECT: usize = 4;
/// Names of the metrics (table headings).
pub const NAMES: [&str; N] = [
    "surface averages",
    "texels",
    "image (no final gather)",
    "image + final gather",
    "image, exact direct + indirect",
];
/// Short keys (file names).
pub const KEYS: [&str; N] = ["surface", "texel", "image", "gather", "direct"];

/// Final-gather rays per pixel sample of the gathered images (the command's former
/// default).
pub const GATHER_RAYS: usize = 8;
/// Shadow rays per emitter and pixel sample of the direct-light images (the command's
/// default `--direct`).
pub const DIRECT_RAYS: usize = 4;
/// Samples per pixel (per axis) of solver images (the command's default).
pub const SOLVER_SPP: usize = 2;
/// √(2/π): `E|N(0, σ²)| = σ √(2/π)`.
const MEAN_ABS: f64 = 0.797_884_560_802_865_4;

/// Sizes of a scene's references.
#[derive(Debug, Clone, Copy)]
pub struct RefSizes {
    /// Texels per m².
    pub texel_density: f64,
    /// Path-traced walks per texel.
    pub texel_paths: u64,
    /// Walks per surface for the surface averages.
    pub surface_samples: u64,
    /// Image side (pixels).
    pub image_px: usize,
    /// Samples per pixel per axis of each of the two half images.
    pub image_spp: usize,
}

/// A scene's references.
pub struct Refs {
    /// The texel grid every method is measured on.
    pub grid: TexelGrid,
    /// Path-traced texel values with standard errors.
    pub texel: Vec<SurfaceEstimate>,
    /// Path-traced surface averages.
    pub surface: Vec<[f64; 3]>,
    /// Area and emission per surface.
    pub areas: Vec<(f64, [f64; 3])>,
    /// The scene camera at `image_px²`.
    pub view: View,
    /// Converged path-traced image (mean of two independent halves).
    pub image: Image,
    /// Emitted radiance at the primary hits (the light-source mask).
    pub emission: Image,
    /// Noise floor per metric (expected error of an exact answer).
    pub floor: [f64; N],
    /// Texel error of the reference's own per-side means against the reference: what
    /// one constant per surface side scores at best with exact means (an unrefined
    /// solution cannot do much better on a concentrated function).
    pub side_constant: f64,
    /// CPU time of all references (s).
    pub seconds: f64,
}

/// The view of the scene's first camera, else an automatic one, `n × n`.
pub fn view_for(scene: &Scene, n: usize) -> anyhow::Result<View> {
    let cam = match scene.cameras.first() {
        Some(c) => c.clone(),
        None => auto_camera(scene, scene_up(scene, false))?,
    };
    Ok(View::new(&cam, n, n)?)
}

/// `Σ_s A_s Σ_c |B_sc − B̂_sc| / Σ_s A_s Σ_c |B̂_sc − E_sc|`: the L1 error of the
/// surface averages relative to the *reflected* radiosity (emitters' `E` is exact for
/// every method and would otherwise dominate the denominator).
pub fn surface_error(b: &[[f64; 3]], reference: &[[f64; 3]], areas: &[(f64, [f64; 3])]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, y), (a, e)) in b.iter().zip(reference).zip(areas) {
        for c in 0..3 {
            num += a * (x[c] - y[c]).abs();
            den += a * (y[c] - e[c]).abs();
        }
    }
    num / den
}

impl Refs {
    /// Computes the references with the path tracer (seed `12345`; the image halves
    /// `12345` and `54321`).
    pub fn new(scene: &Scene, pt: &PathTracer, sz: &RefSizes) -> anyhow::Result<Refs> {
        let t = Stopwatch::start();
        let ro = |seed| ReferenceOptions {
            seed,
            ..ReferenceOptions::default()
        };
        let areas: Vec<(f64, [f64; 3])> = scene
            .surfaces
            .iter()
            .map(|s| (s.shape.area(), scene.materials[s.material].emission.0))
            .collect();
        let mut surface = Vec::new();
        let (mut noise, mut den) = (0.0, 0.0);
        for (s, (a, e)) in areas.iter().enumerate() {
            let est = pt.surface_average(s, sz.surface_samples, &ro(12345))?;
            for c in 0..3 {
                noise += a * est.std_error[c] * MEAN_ABS;
                den += a * (est.mean[c] - e[c]).abs();
            }
            surface.push(est.mean);
        }
        let grid = TexelGrid::new(scene, sz.texel_density)?;
        let texel = pt.texels(&grid, sz.texel_paths, &ro(12345))?;
        let means: Vec<[f64; 3]> = texel.iter().map(|e| e.mean).collect();
        let texel_floor = grid
            .compare_estimates(&means, &texel)?
            .noise_floor
            .unwrap_or(f64::NAN);
        let side_constant = grid
            .compare(&side_means(&grid, &means), &means, None)?
            .relative_l1;
        let view = view_for(scene, sz.image_px)?;
        let h1 = pt.render(&view, sz.image_spp, &ro(12345), &|_| {})?;
        let h2 = pt.render(&view, sz.image_spp, &ro(54321), &|_| {})?;
        let emission = pt.emission_image(&view, 8)?;
        let (half_err, _) = h1.reflected_relative_l1(&h2, &emission)?;
        let mut image = h1.clone();
        for (p, q) in image.pixels.iter_mut().zip(&h2.pixels) {
            for c in 0..3 {
                p[c] = 0.5 * (p[c] + q[c]);
            }
        }
        Ok(Refs {
            grid,
            texel,
            surface,
            areas,
            view,
            image,
            emission,
            floor: [
                noise / den,
                texel_floor,
                0.5 * half_err,
                0.5 * half_err,
                0.5 * half_err,
            ],
            side_constant,
            seconds: t.elapsed().cpu_or_wall(),
        })
    }

    fn image_error(&self, img: &Image) -> anyhow::Result<f64> {
        Ok(img.reflected_relative_l1(&self.image, &self.emission)?.0)
    }

    fn texel_error(&self, values: &[[f64; 3]]) -> anyhow::Result<f64> {
        Ok(self
            .grid
            .compare_estimates(values, &self.texel)?
            .relative_l1)
    }
}

/// Every texel's value replaced by the area-weighted mean of its surface side.
fn side_means(grid: &TexelGrid, values: &[[f64; 3]]) -> Vec<[f64; 3]> {
    let mut sums: std::collections::HashMap<(usize, bool), (f64, [f64; 3])> =
        std::collections::HashMap::new();
    for (t, v) in grid.texels.iter().zip(values) {
        let e = sums.entry((t.surface, t.back)).or_insert((0.0, [0.0; 3]));
        e.0 += t.area;
        for c in 0..3 {
            e.1[c] += t.area * v[c];
        }
    }
    grid.texels
        .iter()
        .map(|t| {
            let (a, s) = sums[&(t.surface, t.back)];
            std::array::from_fn(|c| s[c] / a)
        })
        .collect()
}

/// One measured run: per metric, the CPU time and the error (NaN: not measured).
#[derive(Debug, Clone)]
pub struct Point {
    /// Method label (a series in the plots).
    pub method: String,
    /// Its setting.
    pub setting: String,
    /// CPU time per metric (s; all threads).
    pub time: [f64; N],
    /// Error per metric.
    pub err: [f64; N],
}

/// Measures a solution computed in `solve_s` CPU seconds: surface averages and texels
/// at the solve time (plus the texel evaluation), images at the solve time plus their
/// render time.
pub fn measure_solution(
    method: &str,
    setting: &str,
    sol: &Solution,
    solve_s: f64,
    refs: &Refs,
) -> anyhow::Result<Point> {
    let b: Vec<[f64; 3]> = (0..refs.surface.len())
        .map(|s| sol.surface_average(s))
        .collect();
    let mut p = Point {
        method: method.into(),
        setting: setting.into(),
        time: [f64::NAN; N],
        err: [f64::NAN; N],
    };
    p.time[SURFACE] = solve_s;
    p.err[SURFACE] = surface_error(&b, &refs.surface, &refs.areas);
    let t = Stopwatch::start();
    let field = SolutionField::new(sol)?;
    let build = t.elapsed().cpu_or_wall();
    let t = Stopwatch::start();
    let tv = refs.grid.evaluate(&field);
    p.time[TEXEL] = solve_s + build + t.elapsed().cpu_or_wall();
    p.err[TEXEL] = refs.texel_error(&tv.values)?;
    for (k, gather, direct) in [
        (IMAGE, 0, 0),
        (GATHER, GATHER_RAYS, 0),
        (DIRECT, 0, DIRECT_RAYS),
    ] {
        let t = Stopwatch::start();
        let (img, _) = render(
            &field,
            &refs.view,
            &RenderOptions {
                spp: SOLVER_SPP,
                gather,
                direct,
                seed: 1,
            },
            &|_| {},
        )?;
        p.time[k] = solve_s + build + t.elapsed().cpu_or_wall();
        p.err[k] = refs.image_error(&img)?;
    }
    Ok(p)
}

/// One path-tracer run (seed 777, independent of the references): `samples` walks per
/// surface, `paths` per texel and `spp²` per pixel, each timed on its own.
pub fn measure_path_tracer(
    pt: &PathTracer,
    refs: &Refs,
    samples: u64,
    paths: u64,
    spp: usize,
) -> anyhow::Result<Point> {
    let po = ReferenceOptions {
        seed: 777,
        ..ReferenceOptions::default()
    };
    let mut p = Point {
        method: "path tracer".into(),
        setting: format!("{samples} walks/surface, {paths} walks/texel, {spp}² spp"),
        time: [f64::NAN; N],
        err: [f64::NAN; N],
    };
    let t = Stopwatch::start();
    let mut b = Vec::new();
    for s in 0..refs.surface.len() {
        b.push(pt.surface_average(s, samples, &po)?.mean);
    }
    p.time[SURFACE] = t.elapsed().cpu_or_wall();
    p.err[SURFACE] = surface_error(&b, &refs.surface, &refs.areas);
    let t = Stopwatch::start();
    let tx = pt.texels(&refs.grid, paths, &po)?;
    p.time[TEXEL] = t.elapsed().cpu_or_wall();
    let vals: Vec<[f64; 3]> = tx.iter().map(|e| e.mean).collect();
    p.err[TEXEL] = refs.texel_error(&vals)?;
    let t = Stopwatch::start();
    let img = pt.render(&refs.view, spp, &po, &|_| {})?;
    p.time[IMAGE] = t.elapsed().cpu_or_wall();
    p.err[IMAGE] = refs.image_error(&img)?;
    Ok(p)
}

/// An externally computed run (Mitsuba): texel values and an image, with their CPU
/// times (s).
pub fn measure_external(
    method: &str,
    setting: &str,
    texels: Option<(&[[f64; 3]], f64)>,
    image: Option<(&Image, f64)>,
    refs: &Refs,
) -> anyhow::Result<Point> {
    let mut p = Point {
        method: method.into(),
        setting: setting.into(),
        time: [f64::NAN; N],
        err: [f64::NAN; N],
    };
    if let Some((v, t)) = texels {
        p.time[TEXEL] = t;
        p.err[TEXEL] = refs.texel_error(v)?;
    }
    if let Some((img, t)) = image {
        p.time[IMAGE] = t;
        p.err[IMAGE] = refs.image_error(img)?;
    }
    Ok(p)
}
