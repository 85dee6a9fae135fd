//! `solve` and `render`: load the scene, plan the chosen method, run it (solve, check
//! the error, render), write the EXR, PNG and JSON, print a summary.
//!
//! Each global-illumination method is one module implementing [`Method`]: `gather`
//! (wavelet radiosity with links), `shoot` (linkless shooting), `reference` (the
//! path tracer), `meshless` (precomputed meshless transfer, one frame), `glossy`
//! (4D Haar radiance with Ward BRDFs and importance) and `global_cube` (volume
//! radiosity of a medium); `wavelet` holds what gathering and shooting share
//! (statistics, surface averages, the error check and the image of a wavelet
//! [`Solution`]). Adding a method
//! is a new module, a `MethodArg` variant and one arm in [`plan`].

mod device;
mod error_check;
mod gather;
mod global_cube;
pub mod glossy;
mod meshless;
mod output;
mod reference;
mod relight;
mod scenes;
mod shoot;
mod summary;
mod target;
mod texels;
mod view;
mod warnings;
mod wavelet;

use std::time::{Duration, Instant};

use anyhow::{Context, bail};
use wavelux::render::{Image, ReferenceOptions, View};
use wavelux::scene::Scene;
use wavelux::solver::Solution;

pub use device::NoDevice;
pub use relight::run as relight;
pub use scenes::{list_scenes, load_scene};
pub use texels::{SCHEMA as TEXEL_SCHEMA, TexelFile, grid_of as texel_grid, read as read_texels};

use crate::cli::{CameraArgs, MeshGroupingArg, MethodArg, SolveArgs, SolverArg};
use crate::progress;
use crate::report;

/// One global-illumination method of `solve`, planned from the arguments.
pub trait Method {
    /// The JSON's `method` object: `base` (the common fields, every knob null) with
    /// this method's name and knobs filled in.
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo;
    /// Solves `job.scene`, checks the error and renders `job.view` when there is one;
    /// fills the method's entries of `stats`.
    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome>;
    /// The summary's `method` line (after `  method      `).
    fn describe(&self, r: &report::Result) -> String;
    /// Whether the method has a GPU kernel for its settings (`--device`); `Err` says
    /// why not.
    fn gpu_kernel(&self) -> Result<(), String> {
        Err("this method has no GPU kernel yet".into())
    }
}

/// What a method runs on.
pub struct Job<'a> {
    /// The arguments.
    pub args: &'a SolveArgs,
    /// The validated scene.
    pub scene: &'a Scene,
    /// The file stem of the outputs (`OUT/STEM.exr`, ...).
    pub stem: &'a str,
    /// The image's view (`None` with `--no-image`).
    pub view: Option<&'a View>,
    /// Whether progress bars are shown.
    pub show_progress: bool,
    /// Options of every Monte Carlo estimate (seeded by `--seed`).
    pub reference: ReferenceOptions,
    /// The device of the method's GPU kernels (`--device`).
    pub device: &'a device::Device,
}

/// What a method produced.
pub struct Outcome {
    /// One result per scene surface, in scene order.
    pub surfaces: Vec<report::SurfaceResult>,
    /// The error estimate against a path-traced check (`None` when skipped).
    pub error_estimate: Option<report::ErrorEstimate>,
    /// Why the check was skipped (`None` when it ran, and for methods that report
    /// their own statistical error).
    pub error_estimate_skipped: Option<String>,
    /// Warnings of the run (e.g. a check that could not run).
    pub warnings: Vec<report::WarningInfo>,
    /// The image (`None` with `--no-image`).
    pub image: Option<Image>,
    /// The wavelet solution, for `--gltf` and `--lightmaps` (`None` for methods
    /// without one).
    pub solution: Option<Solution>,
}

/// The method of the arguments: `--method reference` → the path tracer; `--method
/// shoot` or `--solver southwell` → the shooting solver (which *is* Southwell
/// iteration: the patch with the largest unshot power is relaxed next); otherwise
/// gathering with the chosen linear solver: with `--target-error`, or by default
/// ([`target::default_target`]), the target-error loop; with `--eps`, `--oracle`,
/// `--max-level` or `--basis cdv` one fixed-threshold refinement. Inconsistent or
/// invalid choices are errors.
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    if let Some(t) = a.target_error.or_else(|| target::default_target(a)) {
        if a.method != MethodArg::Gather {
            bail!("--target-error applies to --method gather");
        }
        return target::plan(a, t);
    }
    for (given, flag) in [
        (a.face_target.is_some(), "--face-target"),
        (a.face_channels, "--face-channels"),
        (a.estimate_visibility.is_some(), "--estimate-visibility"),
    ] {
        if given {
            bail!(
                "{flag} applies to the target-error loop (--target-error, or a gather \
                 solve without --eps, --oracle, --max-level or --basis cdv)"
            );
        }
    }
    match a.method {
        MethodArg::Reference => reference::plan(a),
        MethodArg::Shoot => shoot::plan(a),
        MethodArg::Gather if a.solver == Some(SolverArg::Southwell) => shoot::plan(a),
        MethodArg::Gather => gather::plan(a),
        MethodArg::Meshless => meshless::plan(a),
        MethodArg::Glossy => glossy::plan(a),
        MethodArg::GlobalCube => global_cube::plan(a),
    }
}

/// Runs `solve` (camera = None) or `render`.
pub fn run(a: &SolveArgs, cam: Option<&CameraArgs>) -> anyhow::Result<()> {
    let t_start = Instant::now();
    let threads = thread_pool(a.threads)?;
    check_image_options(a)?;
    texels::check(a)?;
    let (scene, stem) = load_scene(&a.scene, mesh_grouping(a))?;
    let t_load = t_start.elapsed();
    let method = plan(a)?;
    let mut info = method.info(base_info(a, threads));
    let mut warned = warnings::from_scene(&scene);
    let kernel = method
        .gpu_kernel()
        .map_err(|why| format!("--method {}: {why}", info.name));
    let device = device::choose(a.device, kernel, &mut warned)?;
    warned.extend(warnings::unmodelled(&scene, &info.name, &a.scene));
    warnings::strict(a.strict, &warned)?;
    warnings::print(&warned);
    let view = if a.no_image {
        None
    } else {
        Some(view::choose_view(&scene, a, cam)?)
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create the output directory {:?}", a.out))?;

    let mut stats = report::Statistics::default();
    stats.time_s.load = secs(t_load);
    let job = Job {
        args: a,
        scene: &scene,
        stem: &stem,
        view: view.as_ref(),
        show_progress: progress::enabled(a.quiet),
        reference: ReferenceOptions {
            seed: a.seed,
            ..ReferenceOptions::default()
        },
        device: &device,
    };
    let mut outcome = method.run(&job, &mut stats)?;
    info.device = Some(device.info());
    (stats.device_rays, stats.deferred_rays) = device.rays();
    warnings::strict(a.strict, &outcome.warnings)?;
    warnings::print(&outcome.warnings);
    warned.append(&mut outcome.warnings);

    let t_write = Instant::now();
    let json_path = output::json_path(a, &stem);
    let mut outputs = output::write_files(a, &scene, &stem, &outcome, &json_path)?;
    if let Some(density) = a.texels {
        let p = texels::path(a, &stem);
        texels::write(a, &scene, &outcome, &job.reference, density, &p)?;
        outputs.texels = Some(p.display().to_string());
    }
    stats.time_s.write = secs(t_write.elapsed());
    stats.time_s.total = secs(t_start.elapsed());
    stats.peak_memory_bytes = peak_memory();
    let result = report::Result {
        schema: report::SCHEMA.into(),
        version: report::VERSION,
        scene: report::SceneInfo {
            source: a.scene.clone(),
            name: scene.name.clone(),
            surfaces: scene.surfaces.len(),
            total_area: scene.total_area(),
            emitted_power: scene.emitted_power(),
        },
        method: info,
        surfaces: outcome.surfaces,
        error_estimate: outcome.error_estimate,
        error_estimate_skipped: outcome.error_estimate_skipped,
        warnings: warned,
        statistics: stats,
        outputs,
    };
    output::write_json(&json_path, &result)?;
    if !a.quiet {
        summary::print_summary(&result, method.as_ref(), outcome.solution.is_some());
    }
    Ok(())
}

/// The mesh grouping of `--mesh-grouping`.
fn mesh_grouping(a: &SolveArgs) -> wavelux::scene::MeshGrouping {
    match a.mesh_grouping {
        MeshGroupingArg::Surfaces => wavelux::scene::MeshGrouping::Surfaces,
        MeshGroupingArg::Triangles => wavelux::scene::MeshGrouping::Triangles,
    }
}

/// Sets up the global thread pool (`--threads`); returns the number of threads.
fn thread_pool(threads: Option<usize>) -> anyhow::Result<usize> {
    match threads {
        Some(0) => bail!("--threads must be >= 1"),
        Some(n) => {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build_global()
                .context("cannot set up the thread pool")?;
            Ok(n)
        }
        None => Ok(rayon::current_num_threads()),
    }
}

/// Checks the image size and sampling options.
fn check_image_options(a: &SolveArgs) -> anyhow::Result<()> {
    if a.width == 0 || a.height == 0 || a.width > 16384 || a.height > 16384 {
        bail!("--width and --height must be in 1..=16384");
    }
    if !(1..=64).contains(&a.spp) {
        bail!("--spp must be in 1..=64");
    }
    Ok(())
}

/// The JSON `method` object with the common fields set and every knob null.
fn base_info(a: &SolveArgs, threads: usize) -> report::MethodInfo {
    report::MethodInfo {
        name: String::new(),
        basis: None,
        eps: None,
        oracle: None,
        max_level: None,
        min_area: None,
        solver: None,
        max_iterations: None,
        tolerance: None,
        visibility: None,
        quad: None,
        cluster: None,
        convergence: None,
        max_shots: None,
        meshless: None,
        glossy: None,
        global_cube: None,
        device: None,
        samples: a.samples,
        threads,
        seed: a.seed,
    }
}

/// The result of one side of surface `i` (`back`; see [`reported_back`]) with that
/// side's material (texture means applied).
fn surface_result(
    scene: &Scene,
    i: usize,
    back: bool,
    radiosity: [f64; 3],
    std_error: Option<[f64; 3]>,
) -> report::SurfaceResult {
    let (reflectance, emission) = side_material(scene, i, back);
    report::SurfaceResult {
        name: scene.surfaces[i].name.clone(),
        area: scene.surfaces[i].shape.area(),
        side: if back { "back" } else { "front" }.into(),
        emission,
        reflectance,
        radiosity,
        std_error,
    }
}

/// Whether surface `i` is reported by its back side: two-sided, with a front that
/// neither reflects nor emits and a back that does. This is how the scene model writes
/// a surface lit from its inside (analytic surfaces face outwards; a mesh sphere facing
/// its centre loads as a black front and its material on the back).
pub(crate) fn reported_back(scene: &Scene, i: usize) -> bool {
    let s = &scene.surfaces[i];
    let lit = |(rho, e): ([f64; 3], [f64; 3])| rho.iter().chain(&e).any(|&v| v > 0.0);
    matches!(s.sides, wavelux::scene::Sidedness::TwoSided { .. })
        && !lit(side_material(scene, i, false))
        && lit(side_material(scene, i, true))
}

/// Reflectance and emission of one side of a surface (texture means applied; the back
/// of a one-sided surface is black).
fn side_material(scene: &Scene, i: usize, back: bool) -> ([f64; 3], [f64; 3]) {
    let id = match (back, scene.surfaces[i].sides) {
        (false, _) => scene.surfaces[i].material,
        (true, wavelux::scene::Sidedness::TwoSided { back }) => back,
        (true, _) => return ([0.0; 3], [0.0; 3]),
    };
    let (rho, e) = scene.materials[id].diffuse_means(&scene.textures);
    (rho.0, e.0)
}

/// A value's `Debug` name in kebab-case (`GaussSeidel` → `gauss-seidel`).
fn name_of<T: std::fmt::Debug>(v: T) -> String {
    let s = format!("{v:?}");
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if c.is_ascii_uppercase() {
            if i > 0 {
                out.push('-');
            }
            out.push(c.to_ascii_lowercase());
        } else {
            out.push(c);
        }
    }
    out
}

/// Peak resident memory of the process (Linux `VmHWM`), bytes.
fn peak_memory() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Seconds of a duration.
fn secs(d: Duration) -> f64 {
    d.as_secs_f64()
}
