//! `solve` and `render`: load, solve (wavelet radiosity or the Monte Carlo reference),
//! estimate the error, render, write the EXR, PNG and JSON, print a summary.

use std::path::Path;
use std::time::Instant;

use anyhow::{Context, bail};
use glam::DVec3;
use wavelux::render::{
    Image, PathTracer, ReferenceOptions, RenderOptions, SolutionField, ToneMap, View,
    image::write_bytes_atomic,
};
use wavelux::scene::{Scene, builtin};
use wavelux::solver::shoot::ShootConfig;
use wavelux::solver::{BasisKind, LinearMethod, Oracle, Solution, SolverConfig, Visibility};

use crate::cli::{BasisArg, CameraArgs, MethodArg, OracleArg, SolveArgs, SolverArg, VisibilityArg};
use crate::progress;
use crate::report;

/// Loads `builtin:NAME` or a scene file, validated.
pub fn load_scene(source: &str) -> anyhow::Result<(Scene, String)> {
    if let Some(name) = source.strip_prefix("builtin:") {
        let scene = builtin::builtin(name).with_context(|| {
            format!(
                "unknown built-in scene {name:?}; `wavelux scenes` lists them: {}",
                builtin::BUILTIN_NAMES.join(", ")
            )
        })?;
        let stem = if name == "cornell-box" {
            "cornell".to_string()
        } else {
            name.to_string()
        };
        return Ok((scene, stem));
    }
    let path = Path::new(source);
    if !path.exists() {
        bail!("scene file {source:?} does not exist (use builtin:NAME for a built-in scene)");
    }
    let scene = wavelux::scene::load(path).with_context(|| format!("cannot load {source:?}"))?;
    scene
        .validate(source)
        .with_context(|| format!("invalid scene {source:?}"))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Ok((scene, stem))
}

/// `wavelux scenes`.
pub fn list_scenes() {
    println!(
        "{:<34} {:>8} {:>8} {:>10}",
        "built-in scene", "surfaces", "cameras", "area m²"
    );
    for name in builtin::BUILTIN_NAMES {
        if let Some(s) = builtin::builtin(name) {
            println!(
                "{:<34} {:>8} {:>8} {:>10.4}",
                format!("builtin:{name}"),
                s.surfaces.len(),
                s.cameras.len(),
                s.total_area()
            );
        }
    }
}

/// What `solve` runs.
#[derive(Debug, Clone)]
pub enum Plan {
    /// Wavelet radiosity with links (gathering).
    Gather(SolverConfig),
    /// Linkless hierarchical shooting on the Virtual Mesh (Southwell order).
    Shoot(ShootConfig),
    /// The Monte Carlo path tracer.
    Reference,
}

/// Default deepest level of the gathering solver.
const GATHER_MAX_LEVEL: u8 = 2;
/// Default deepest level of the shooting solver.
const SHOOT_MAX_LEVEL: u8 = 3;

fn basis_kind(b: BasisArg) -> BasisKind {
    match b {
        BasisArg::Haar => BasisKind::Haar,
        BasisArg::M2 => BasisKind::Multiwavelet(2),
        BasisArg::M3 => BasisKind::Multiwavelet(3),
        BasisArg::Cdv => BasisKind::Cdv,
    }
}

fn visibility(v: VisibilityArg) -> Visibility {
    match v {
        VisibilityArg::Quadrature => Visibility::InQuadrature,
        VisibilityArg::Fractional => Visibility::Fractional,
        VisibilityArg::Off => Visibility::Off,
    }
}

/// The plan of the arguments: `--method reference` → the path tracer; `--method shoot`
/// or `--solver southwell` → the shooting solver (which *is* Southwell iteration: the
/// patch with the largest unshot power is relaxed next); otherwise gathering with the
/// chosen linear solver. Inconsistent or invalid choices are errors.
pub fn plan(a: &SolveArgs) -> anyhow::Result<Plan> {
    if a.method == MethodArg::Reference {
        return Ok(Plan::Reference);
    }
    if a.method == MethodArg::Shoot {
        return shoot_plan(a);
    }
    let linear_method = match a.solver.unwrap_or(SolverArg::Gmres) {
        SolverArg::Picard | SolverArg::Jacobi => LinearMethod::Picard,
        SolverArg::GaussSeidel => LinearMethod::GaussSeidel,
        SolverArg::Gmres => LinearMethod::Gmres { restart: 30 },
        SolverArg::Cgnr => LinearMethod::Cgnr,
        SolverArg::Southwell => return shoot_plan(a),
    };
    let cfg = SolverConfig {
        basis: basis_kind(a.basis.unwrap_or(BasisArg::M3)),
        eps: a.eps,
        max_level: a.max_level.unwrap_or(GATHER_MAX_LEVEL),
        min_area: a.min_area,
        oracle: match a.oracle {
            OracleArg::Kernel => Oracle::KernelSmoothness,
            OracleArg::Brightness => Oracle::Brightness,
        },
        visibility: visibility(a.visibility),
        quad_points: a.quad,
        linear_method,
        max_iterations: a.max_iterations,
        tolerance: a.tolerance,
        ..SolverConfig::default()
    };
    cfg.validate().context("invalid solver option")?;
    Ok(Plan::Gather(cfg))
}

/// The shooting plan (`--method shoot` or `--solver southwell`).
fn shoot_plan(a: &SolveArgs) -> anyhow::Result<Plan> {
    if let Some(s) = a.solver.filter(|s| *s != SolverArg::Southwell) {
        bail!(
            "--solver {} applies to --method gather; shooting is Southwell iteration \
             (omit --solver or use --solver southwell)",
            name_of(s)
        );
    }
    if a.oracle != OracleArg::Kernel {
        bail!("--oracle applies to --method gather; the shooting oracle is relative to the shot");
    }
    let cfg = ShootConfig {
        basis: basis_kind(a.basis.unwrap_or(BasisArg::Haar)),
        eps: a.eps,
        max_level: a.max_level.unwrap_or(SHOOT_MAX_LEVEL),
        min_area: a.min_area,
        quad_points: a.quad,
        visibility: visibility(a.visibility),
        convergence: a.convergence,
        max_shots: a.max_shots,
        ..ShootConfig::default()
    };
    cfg.validate().context("invalid shooting option")?;
    Ok(Plan::Shoot(cfg))
}

fn name_of<T: std::fmt::Debug>(v: T) -> String {
    let s = format!("{v:?}");
    // CamelCase → kebab-case.
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

/// Front-side reflectance and emission of a surface (texture means applied).
fn front_material(scene: &Scene, i: usize) -> ([f64; 3], [f64; 3]) {
    let m = &scene.materials[scene.surfaces[i].material];
    let mut rho = m.reflectance.0;
    let mut e = m.emission.0;
    if let Some(t) = m
        .reflectance_texture
        .and_then(|t| scene.textures.get(t.texture))
    {
        let t = t.mean().0;
        rho = std::array::from_fn(|c| rho[c] * t[c]);
    }
    if let Some(t) = m
        .emission_texture
        .and_then(|t| scene.textures.get(t.texture))
    {
        let t = t.mean().0;
        e = std::array::from_fn(|c| e[c] * t[c]);
    }
    (rho, e)
}

/// The view: camera flags, else the named or first scene camera, else an automatic one.
fn choose_view(scene: &Scene, a: &SolveArgs, cam: Option<&CameraArgs>) -> anyhow::Result<View> {
    let (w, h) = (a.width, a.height);
    if let Some(c) = cam {
        if let (Some(eye), Some(target)) = (&c.eye, &c.target) {
            let v = |x: &Vec<f64>, what: &str| -> anyhow::Result<DVec3> {
                match x.as_slice() {
                    [a, b, c] => Ok(DVec3::new(*a, *b, *c)),
                    _ => bail!("--{what} needs three comma-separated numbers x,y,z"),
                }
            };
            return View::look_at(
                v(eye, "eye")?,
                v(target, "target")?,
                v(&c.up, "up")?,
                c.fov.to_radians(),
                w,
                h,
            )
            .context("invalid look-at camera");
        }
        if let Some(name) = &c.camera {
            let camera = scene
                .cameras
                .iter()
                .find(|k| &k.name == name)
                .with_context(|| {
                    let names: Vec<&str> = scene.cameras.iter().map(|k| k.name.as_str()).collect();
                    format!("the scene has no camera {name:?} (cameras: {names:?})")
                })?;
            return View::new(camera, w, h).context("invalid scene camera");
        }
    }
    if let Some(camera) = scene.cameras.first() {
        return View::new(camera, w, h).context("invalid scene camera");
    }
    let up = wavelux::render::scene_up(scene, is_gltf(&a.scene));
    Ok(View::new(&wavelux::render::auto_camera(scene, up)?, w, h)?)
}

/// Whether a scene source names a glTF file (`.gltf`/`.glb`: `+y` up).
fn is_gltf(source: &str) -> bool {
    Path::new(source)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}

fn peak_memory() -> Option<u64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

fn secs(d: std::time::Duration) -> f64 {
    d.as_secs_f64()
}

/// Runs `solve` (camera = None) or `render`.
pub fn run(a: &SolveArgs, cam: Option<&CameraArgs>) -> anyhow::Result<()> {
    let t_start = Instant::now();
    let threads = match a.threads {
        Some(0) => bail!("--threads must be >= 1"),
        Some(n) => {
            rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build_global()
                .context("cannot set up the thread pool")?;
            n
        }
        None => rayon::current_num_threads(),
    };
    if a.width == 0 || a.height == 0 || a.width > 16384 || a.height > 16384 {
        bail!("--width and --height must be in 1..=16384");
    }
    if !(1..=64).contains(&a.spp) {
        bail!("--spp must be in 1..=64");
    }
    let show = progress::enabled(a.quiet);
    let (scene, stem) = load_scene(&a.scene)?;
    let t_load = t_start.elapsed();
    let plan = plan(a)?;
    let view = if a.no_image {
        None
    } else {
        Some(choose_view(&scene, a, cam)?)
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create the output directory {:?}", a.out))?;

    let mut stats = report::Statistics::default();
    stats.time_s.load = secs(t_load);
    let ropts = ReferenceOptions {
        seed: a.seed,
        ..ReferenceOptions::default()
    };
    let mut surfaces = Vec::with_capacity(scene.surfaces.len());
    let mut error_estimate = None;
    let mut image: Option<Image> = None;
    let mut solution: Option<Solution> = None;

    let solved = match &plan {
        Plan::Gather(cfg) => {
            let sp = progress::spinner(show, "refining and solving");
            let sol = wavelux::solver::solve(&scene, cfg);
            sp.finish_and_clear();
            Some(sol)
        }
        Plan::Shoot(cfg) => {
            let sp = progress::spinner(show, "shooting");
            let sol = wavelux::solver::shoot::shoot(&scene, cfg);
            sp.finish_and_clear();
            Some(sol)
        }
        Plan::Reference => None,
    };
    match solved {
        Some(sol) => {
            let sol = sol.with_context(|| format!("solving {:?} failed", a.scene))?;
            let st = &sol.stats;
            stats.time_s.setup = secs(st.time_setup);
            stats.time_s.refine = secs(st.time_refine);
            stats.time_s.solve = secs(st.time_solve);
            stats.elements = st.elements;
            stats.leaves = st.leaves;
            stats.links = st.links;
            stats.refined_links = st.refined_links;
            stats.oracle_evaluations = st.oracle_evals;
            stats.kernel_evaluations = st.kernel_evals;
            stats.solver_rays = st.rays;
            stats.solver_bytes = st.bytes;
            stats.iterations = st.iterations.clone();
            stats.residual_history = sol
                .convergence
                .iter()
                .map(|c| c.iterations.iter().map(|r| r.relative_residual).collect())
                .collect();
            if let Plan::Shoot(_) = plan {
                stats.shots = Some(st.shots);
                stats.shooting_surfaces = Some(st.shooting_surfaces);
                stats.convergence_history = st.shot_convergence.clone();
            }
            stats.energy = Some(report::Energy {
                emitted: sol.energy.emitted,
                absorbed: sol.energy.absorbed,
                escaped: sol.energy.escaped,
                unshot: sol.energy.unshot,
            });
            for i in 0..scene.surfaces.len() {
                let (rho, e) = front_material(&scene, i);
                surfaces.push(report::SurfaceResult {
                    name: scene.surfaces[i].name.clone(),
                    area: scene.surfaces[i].shape.area(),
                    emission: e,
                    reflectance: rho,
                    radiosity: sol.surface_average(i),
                    std_error: None,
                });
            }
            if a.samples > 0 {
                let t = Instant::now();
                let sp = progress::spinner(show, "Monte Carlo error check");
                error_estimate = estimate_error(&scene, &surfaces, a.samples, &ropts);
                sp.finish_and_clear();
                stats.time_s.monte_carlo = secs(t.elapsed());
            }
            if let Some(view) = &view {
                let t = Instant::now();
                let field = SolutionField::new(&sol)?;
                let pb = progress::bar(show, view.height as u64, "rendering");
                let (img, rs) = wavelux::render::render(
                    &field,
                    view,
                    &RenderOptions {
                        spp: a.spp,
                        gather: a.gather,
                        seed: a.seed,
                    },
                    &|k| pb.inc(k),
                )?;
                pb.finish_and_clear();
                stats.primary_rays = rs.primary_rays;
                stats.gather_rays = rs.gather_rays;
                stats.time_s.render = secs(t.elapsed());
                image = Some(img);
            }
            solution = Some(sol);
        }
        None => {
            let t = Instant::now();
            if a.samples == 0 {
                bail!("--method reference needs --samples >= 1");
            }
            let pt = PathTracer::new(&scene)?;
            let pb = progress::bar(show, scene.surfaces.len() as u64, "path tracing");
            for i in 0..scene.surfaces.len() {
                let est = pt
                    .surface_average(i, a.samples, &ropts)
                    .with_context(|| format!("surface {:?}", scene.surfaces[i].name))?;
                let (rho, e) = front_material(&scene, i);
                surfaces.push(report::SurfaceResult {
                    name: scene.surfaces[i].name.clone(),
                    area: scene.surfaces[i].shape.area(),
                    emission: e,
                    reflectance: rho,
                    radiosity: est.mean,
                    std_error: Some(est.std_error),
                });
                pb.inc(1);
            }
            pb.finish_and_clear();
            stats.time_s.monte_carlo = secs(t.elapsed());
            if let Some(view) = &view {
                let t = Instant::now();
                let pb = progress::bar(show, view.height as u64, "rendering");
                let img = pt.render(view, a.spp, &ropts, &|k| pb.inc(k))?;
                pb.finish_and_clear();
                stats.primary_rays = (view.width * view.height * a.spp * a.spp) as u64;
                stats.time_s.render = secs(t.elapsed());
                image = Some(img);
            }
        }
    }

    // Outputs.
    let t_write = Instant::now();
    let json_path = a
        .json
        .clone()
        .unwrap_or_else(|| a.out.join(format!("{stem}.json")));
    let mut outputs = report::Outputs {
        json: Some(json_path.display().to_string()),
        ..report::Outputs::default()
    };
    if let Some(img) = &image {
        let exr = a.out.join(format!("{stem}.exr"));
        let png = a.out.join(format!("{stem}.png"));
        img.write_exr(&exr)?;
        img.write_png(&png, ToneMap::Auto)?;
        outputs.exr = Some(exr.display().to_string());
        outputs.png = Some(png.display().to_string());
    }
    if let Some(sol) = &solution {
        let names: Vec<String> = scene.surfaces.iter().map(|s| s.name.clone()).collect();
        if let Some(g) = &a.gltf {
            wavelux::render::export::write_gltf(sol, &names, g, 2)
                .with_context(|| format!("glTF export to {g:?}"))?;
            outputs.gltf = Some(g.display().to_string());
        }
        if let Some(res) = a.lightmaps {
            let dir = a.out.join(format!("{stem}-lightmaps"));
            wavelux::render::export::write_lightmaps(sol, &names, &dir, res)?;
            outputs.lightmaps = Some(dir.display().to_string());
        }
    } else if a.gltf.is_some() || a.lightmaps.is_some() {
        bail!("--gltf and --lightmaps export a wavelet solution; --method reference has none");
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
        method: method_info(a, &plan, threads),
        surfaces,
        error_estimate,
        statistics: stats,
        outputs,
    };
    let text = serde_json::to_string_pretty(&result)?;
    if let Some(dir) = json_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the directory of {json_path:?}"))?;
    }
    write_bytes_atomic(&json_path, text.as_bytes())?;
    if !a.quiet {
        print_summary(&result, solution.as_ref());
    }
    Ok(())
}

fn method_info(a: &SolveArgs, plan: &Plan, threads: usize) -> report::MethodInfo {
    let none = report::MethodInfo {
        name: "reference".into(),
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
        convergence: None,
        max_shots: None,
        samples: a.samples,
        threads,
        seed: a.seed,
    };
    match plan {
        Plan::Gather(c) => report::MethodInfo {
            name: "gather".into(),
            basis: Some(c.basis.name()),
            eps: Some(c.eps),
            oracle: Some(name_of(a.oracle)),
            max_level: Some(c.max_level),
            min_area: Some(c.min_area),
            solver: Some(name_of(a.solver.unwrap_or(SolverArg::Gmres))),
            max_iterations: Some(c.max_iterations),
            tolerance: Some(c.tolerance),
            visibility: Some(name_of(a.visibility)),
            quad: Some(c.quad_points),
            ..none
        },
        Plan::Shoot(c) => report::MethodInfo {
            name: "shoot".into(),
            basis: Some(c.basis.name()),
            eps: Some(c.eps),
            max_level: Some(c.max_level),
            min_area: Some(c.min_area),
            solver: Some("southwell".into()),
            visibility: Some(name_of(a.visibility)),
            quad: Some(c.quad_points),
            convergence: Some(c.convergence),
            max_shots: Some(c.max_shots),
            ..none
        },
        Plan::Reference => none,
    }
}

/// Compares surface averages with a quick path-traced check.
fn estimate_error(
    scene: &Scene,
    surfaces: &[report::SurfaceResult],
    samples: u64,
    opts: &ReferenceOptions,
) -> Option<report::ErrorEstimate> {
    let pt = PathTracer::new(scene).ok()?;
    let (mut num, mut den, mut noise, mut max_z) = (0.0, 0.0, 0.0, 0.0f64);
    for (i, s) in surfaces.iter().enumerate() {
        let est = pt.surface_average(i, samples, opts).ok()?;
        for c in 0..3 {
            let d = (s.radiosity[c] - est.mean[c]).abs();
            num += s.area * d;
            den += s.area * (est.mean[c] - s.emission[c]).abs();
            noise += s.area * est.std_error[c];
            if est.std_error[c] > 0.0 {
                max_z = max_z.max(d / est.std_error[c]);
            }
        }
    }
    (den > 0.0).then(|| report::ErrorEstimate {
        relative_l1: num / den,
        check_noise: noise / den,
        max_z,
        samples,
    })
}

fn mib(b: u64) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

fn print_summary(r: &report::Result, sol: Option<&Solution>) {
    let m = &r.method;
    let st = &r.statistics;
    println!(
        "wavelux {} — {} ({})",
        env!("CARGO_PKG_VERSION"),
        r.scene.name,
        r.scene.source
    );
    match m.name.as_str() {
        "gather" => println!(
            "  method      wavelet radiosity (gather), basis {}, eps {:e} ({} oracle), max level {}, {} solver, {} visibility, {}x{} quadrature",
            m.basis.as_deref().unwrap_or("?"),
            m.eps.unwrap_or(0.0),
            m.oracle.as_deref().unwrap_or("?"),
            m.max_level.unwrap_or(0),
            m.solver.as_deref().unwrap_or("?"),
            m.visibility.as_deref().unwrap_or("?"),
            m.quad.unwrap_or(0),
            m.quad.unwrap_or(0),
        ),
        "shoot" => println!(
            "  method      linkless shooting on the Virtual Mesh (Southwell), basis {}, eps {:e} (relative), max level {}, convergence {} ({} shots, {} shooting surfaces), {} visibility, {}x{} quadrature",
            m.basis.as_deref().unwrap_or("?"),
            m.eps.unwrap_or(0.0),
            m.max_level.unwrap_or(0),
            st.convergence_history.last().copied().unwrap_or(0.0),
            st.shots.unwrap_or(0),
            st.shooting_surfaces.unwrap_or(0),
            m.visibility.as_deref().unwrap_or("?"),
            m.quad.unwrap_or(0),
            m.quad.unwrap_or(0),
        ),
        _ => println!(
            "  method      Monte Carlo path tracer, {} samples per surface",
            m.samples
        ),
    }
    match &r.error_estimate {
        Some(e) => println!(
            "  error       {:.2}% relative L1 of surface averages vs a {}-sample path-traced check (check noise {:.2}%, max |z| {:.1})",
            100.0 * e.relative_l1,
            e.samples,
            100.0 * e.check_noise,
            e.max_z
        ),
        None if m.name == "reference" => {
            let rel: f64 = r
                .surfaces
                .iter()
                .map(|s| {
                    s.std_error
                        .map_or(0.0, |se| s.area * se.iter().sum::<f64>())
                })
                .sum::<f64>()
                / r.surfaces
                    .iter()
                    .map(|s| s.area * s.radiosity.iter().sum::<f64>())
                    .sum::<f64>()
                    .max(f64::MIN_POSITIVE);
            println!(
                "  error       {:.3}% (area-weighted standard error)",
                100.0 * rel
            );
        }
        None => println!("  error       not estimated (--samples 0)"),
    }
    if sol.is_some() {
        let res = st
            .residual_history
            .iter()
            .filter_map(|h| h.last().copied())
            .fold(0.0f64, f64::max);
        println!(
            "  elements    {} ({} leaves), links {}, kernel evaluations {}, iterations {:?}, residual {:.1e}",
            st.elements, st.leaves, st.links, st.kernel_evaluations, st.iterations, res
        );
    }
    println!(
        "  rays        {} solver shadow, {} primary, {} gather",
        st.solver_rays, st.primary_rays, st.gather_rays
    );
    let t = &st.time_s;
    println!(
        "  time        {:.2} s total: setup {:.2}, refine {:.2}, solve {:.2}, Monte Carlo {:.2}, render {:.2}, write {:.2} ({} threads)",
        t.total, t.setup, t.refine, t.solve, t.monte_carlo, t.render, t.write, m.threads
    );
    println!(
        "  memory      {:.1} MiB solver, {} peak",
        mib(st.solver_bytes as u64),
        st.peak_memory_bytes
            .map_or("unknown".to_string(), |b| format!("{:.1} MiB", mib(b)))
    );
    println!("  surfaces    name: radiosity W/m² (R, G, B)");
    for s in r.surfaces.iter().take(12) {
        println!(
            "    {:<28} {:>10.4} {:>10.4} {:>10.4}",
            s.name, s.radiosity[0], s.radiosity[1], s.radiosity[2]
        );
    }
    if r.surfaces.len() > 12 {
        println!("    ... {} more in the JSON", r.surfaces.len() - 12);
    }
    let o = &r.outputs;
    for p in [&o.exr, &o.png, &o.json, &o.gltf, &o.lightmaps]
        .into_iter()
        .flatten()
    {
        println!("  wrote       {p}");
    }
}
