//! `--method glossy`: glossy global illumination with 4D Haar radiance and importance
//! (Glossy §3–§5; `wavelux-glossy`). Ward lobes, cosine-power emitters and textures
//! are modelled. The solution is refined for `--rounds` rounds (importance from the
//! image's camera with `--importance camera`, or from named surfaces with
//! `--importance-surfaces`), surface results are the real-area mean exitances of the
//! front sides, the error check compares them with the glossy path tracer
//! (`--samples` per surface), and the image shows the radiance toward the camera: the
//! reflected expansion plus exact emission, or with `--gather N` the final gather
//! (§5.5) of `--gather-mode` with `N` rays per sending node.

use std::time::Instant;

use anyhow::{Context, bail};
use clap::ValueEnum;
use wavelux::glossy::{
    Decomposition, DirectionKind, GatherMode, GlossyConfig, GlossySolution, ImportanceSource,
    LinearSolver, TransportOptions, WardVariant,
};
use wavelux::render::{GlossyField, GlossyTracer, RadianceOptions, View, render_radiance};
use wavelux::scene::{Camera, Projection};
use wavelux::support::Side;

use super::{Job, Method, Outcome, error_check, secs, surface_result, warnings};
use crate::cli::{SolveArgs, SolverArg};
use crate::progress;
use crate::report;

/// Default deepest node level of the glossy method.
const MAX_LEVEL: u8 = 5;

/// Radiance shown on the black back of one-sided surfaces (W/(m²·sr)): a dim grey
/// that marks them without passing for lit surfaces.
const BACK_FACE: [f64; 3] = [0.02; 3];

/// Ward normalisation (`--ward-variant`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum WardVariantArg {
    /// The paper's `1/(4π α_x α_y √(cos θ_i cos θ_o))`.
    Original,
    /// `1/(4π α_x α_y cos θ_i cos θ_o)`.
    Product,
    /// `(h·h)/(π α_x α_y (h·n)⁴)`, albedo below 1 (default).
    Bounded,
}

/// Hemisphere ↔ square map (`--directions`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum DirectionsArg {
    /// The paper's map (§3.3).
    Glossy,
    /// Equal-area concentric map.
    Concentric,
    /// Cosine-weighted map (ours, default): every projection keeps its cell's exitance.
    Cosine,
}

/// Final-gather senders (`--gather-mode`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum GatherModeArg {
    /// Every basis function of every patch.
    All,
    /// Senders linked to a function supporting the point and direction.
    Linked,
    /// Senders linked to the point's root function (fastest).
    Root,
}

/// Operator decomposition (`--decomposition`, Glossy §3.5).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum DecompositionArg {
    /// The paper's: a sending function to a node's wavelets at any level.
    Standard,
    /// Scaling links between nodes' `φ` with push/pull (importance off).
    NonStandard,
}

/// Importance source (`--importance`).
#[derive(Copy, Clone, Debug, PartialEq, Eq, ValueEnum)]
pub enum ImportanceArg {
    /// View-independent refinement.
    Off,
    /// An eye patch at the image's camera emits importance inside its view.
    Camera,
}

/// The glossy method with its configuration.
struct Glossy {
    /// The configuration (importance `Off` until [`Glossy::bound`] when `camera`).
    config: GlossyConfig,
    /// `--importance camera`: the eye patch sits at the image's camera.
    camera: bool,
    gather: Option<(GatherMode, usize)>,
}

/// The glossy plan of the arguments (`--solver` gauss-seidel [default], picard or
/// gmres; the glossy knobs of [`crate::cli::GlossyArgs`]), checked by
/// [`GlossyConfig::validate`]. The importance camera is bound in [`Method::run`].
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    let g = &a.glossy;
    let solver = match a.solver.unwrap_or(SolverArg::GaussSeidel) {
        SolverArg::GaussSeidel => LinearSolver::GaussSeidel,
        SolverArg::Picard | SolverArg::Jacobi => LinearSolver::Picard,
        SolverArg::Gmres => LinearSolver::Gmres,
        s => bail!("--method glossy solves by gauss-seidel, picard or gmres, not {s:?}"),
    };
    let importance = match (g.importance, &g.importance_surfaces) {
        (ImportanceArg::Camera, Some(_)) => {
            bail!("--importance camera and --importance-surfaces exclude each other")
        }
        (_, Some(names)) => ImportanceSource::Surfaces(names.clone()),
        // The camera is bound to the view in `run`.
        (ImportanceArg::Off | ImportanceArg::Camera, None) => ImportanceSource::Off,
    };
    let config = GlossyConfig {
        variant: match g.ward_variant {
            WardVariantArg::Original => WardVariant::Original,
            WardVariantArg::Product => WardVariant::Product,
            WardVariantArg::Bounded => WardVariant::Bounded,
        },
        directions: match g.directions {
            DirectionsArg::Glossy => DirectionKind::Glossy,
            DirectionsArg::Concentric => DirectionKind::Concentric,
            DirectionsArg::Cosine => DirectionKind::Cosine,
        },
        solver,
        decomposition: match g.decomposition {
            DecompositionArg::Standard => Decomposition::Standard,
            DecompositionArg::NonStandard => Decomposition::NonStandard,
        },
        tolerance: a.tolerance.unwrap_or(1e-6),
        max_iterations: a.max_iterations,
        rounds: g.rounds,
        fraction: g.fraction,
        importance,
        max_links: g.glossy_max_links,
        max_bytes: g.max_bytes,
        max_level: a.max_level.unwrap_or(MAX_LEVEL),
        transport: TransportOptions {
            spatial: g.spatial_samples,
            angular: g.angular_samples,
            lobe: g.lobe_samples,
            ..TransportOptions::default()
        },
        image_tolerance: g.image_tolerance,
        seed: a.seed,
        ..GlossyConfig::default()
    };
    config.validate().context("--method glossy")?;
    if g.image_tolerance.is_some() && g.importance != ImportanceArg::Camera {
        bail!("--image-tolerance watches the camera's image: it needs --importance camera");
    }
    let gather = (a.gather > 0).then(|| {
        let mode = match g.gather_mode {
            GatherModeArg::All => GatherMode::All,
            GatherModeArg::Linked => GatherMode::Linked,
            GatherModeArg::Root => GatherMode::Root,
        };
        (mode, a.gather)
    });
    Ok(Box::new(Glossy {
        config,
        camera: g.importance == ImportanceArg::Camera,
        gather,
    }))
}

/// The scene camera of an image view (perspective only: the eye patch needs an eye
/// point).
fn camera_of(view: &View) -> anyhow::Result<Camera> {
    let Projection::Perspective { yfov, .. } = view.projection else {
        bail!("--importance camera needs a perspective camera");
    };
    Ok(Camera {
        name: "view".into(),
        position: view.position,
        forward: view.forward,
        up: view.up,
        projection: Projection::Perspective {
            yfov,
            aspect: Some(view.width as f64 / view.height as f64),
        },
    })
}

impl Glossy {
    /// The configuration with the importance camera bound to the job's view.
    fn bound(&self, job: &Job<'_>) -> anyhow::Result<GlossyConfig> {
        let mut c = self.config.clone();
        if self.camera {
            let view = job
                .view
                .context("--importance camera needs the image's camera (not --no-image)")?;
            c.importance = ImportanceSource::Camera {
                camera: camera_of(view)?,
                aspect: view.width as f64 / view.height as f64,
            };
        }
        Ok(c)
    }
}

impl Method for Glossy {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        let c = &self.config;
        report::MethodInfo {
            name: "glossy".into(),
            basis: Some("haar-4d".into()),
            max_level: Some(c.max_level),
            solver: Some(c.solver.name().into()),
            max_iterations: Some(c.max_iterations),
            tolerance: Some(c.tolerance),
            glossy: serde_json::to_value(GlossyInfo {
                variant: c.variant.name(),
                decomposition: c.decomposition.name(),
                directions: c.directions.name(),
                rounds: c.rounds,
                fraction: c.fraction,
                importance: match &c.importance {
                    _ if self.camera => "camera".into(),
                    ImportanceSource::Off => "off".into(),
                    ImportanceSource::Surfaces(v) => format!("surfaces {}", v.join(",")),
                    ImportanceSource::Camera { .. } => "camera".into(),
                },
                max_links: c.max_links,
                max_bytes: c.max_bytes,
                transport: c.transport,
                image_tolerance: c.image_tolerance,
                gather_mode: self.gather.map(|g| g.0.name()),
                gather_rays: self.gather.map_or(0, |g| g.1),
            })
            .ok(),
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let (scene, a) = (job.scene, job.args);
        let config = self.bound(job)?;
        let sp = progress::spinner(job.show_progress, "glossy: initial links and V⁰ solve");
        let sol = GlossySolution::new(scene, &a.scene, config);
        sp.finish_and_clear();
        let mut sol = sol.with_context(|| format!("solving {:?} failed", a.scene))?;
        let pb = progress::bar(job.show_progress, sol.config.rounds as u64, "refining");
        sol.run(|_| pb.inc(1))
            .with_context(|| format!("refining {:?} failed", a.scene))?;
        pb.finish_and_clear();
        let gs = &sol.stats;
        stats.time_s.setup = gs.times.setup;
        stats.time_s.refine = gs.times.initial_links + gs.times.refine;
        stats.time_s.solve = gs.times.initial_solve + gs.times.solve;
        stats.links = gs.links;
        stats.solver_rays = gs.rays;
        stats.kernel_evaluations = gs.samples;
        stats.solver_bytes = sol.bytes();
        stats.glossy = serde_json::to_value(gs).ok();
        let mut warned: Vec<report::WarningInfo> = gs
            .warnings
            .iter()
            .map(|w| report::WarningInfo {
                kind: "glossy".into(),
                file: Some(a.scene.clone()),
                element: String::new(),
                message: w.clone(),
                use_method: None,
            })
            .collect();
        let surfaces: Vec<report::SurfaceResult> = (0..scene.surfaces.len())
            .map(|i| {
                let m = sol.side_exitance(i, Side::Front).unwrap_or([0.0; 3]);
                surface_result(scene, i, false, m, None)
            })
            .collect();
        let tracer = GlossyTracer::new(&sol.scene);
        let mut check = Err("--samples 0".to_string());
        if a.samples > 0 {
            let t = Instant::now();
            let sp = progress::spinner(job.show_progress, "Monte Carlo error check");
            check = error_check::compare(&surfaces, a.samples, |i| {
                tracer
                    .side_exitance(i, Side::Front, a.samples, &job.reference)
                    .map_err(|e| e.to_string())
            });
            sp.finish_and_clear();
            stats.time_s.monte_carlo = secs(t.elapsed());
            if let Err(reason) = &check {
                warned.push(warnings::error_check_skipped(reason));
            }
        }
        let (error_estimate, error_estimate_skipped) = match check {
            Ok(e) => (Some(e), None),
            Err(reason) => (None, Some(reason)),
        };
        let mut image = None;
        if let Some(view) = job.view {
            let t = Instant::now();
            let pb = progress::bar(job.show_progress, view.height as u64, "rendering");
            let field = GlossyField {
                solution: &sol,
                gather: self.gather,
            };
            let img = render_radiance(
                &field,
                view,
                &RadianceOptions {
                    spp: a.spp,
                    seed: a.seed,
                    back_face: BACK_FACE,
                },
                &|k| pb.inc(k),
            )?;
            pb.finish_and_clear();
            stats.primary_rays = (view.width * view.height * a.spp * a.spp) as u64;
            stats.time_s.render = secs(t.elapsed());
            image = Some(img);
        }
        Ok(Outcome {
            surfaces,
            error_estimate,
            error_estimate_skipped,
            warnings: warned,
            image,
            solution: None,
        })
    }

    fn describe(&self, r: &report::Result) -> String {
        let c = &self.config;
        let links = r.statistics.links;
        format!(
            "glossy (4D Haar radiance), Ward {}, {} rounds (fraction {}), max level {}, {} \
             solver, {links} links{}",
            c.variant.name(),
            c.rounds,
            c.fraction,
            c.max_level,
            c.solver.name(),
            match self.gather {
                Some((m, n)) => format!(", final gather {} x {n}", m.name()),
                None => String::new(),
            }
        )
    }
}

/// The JSON's `method.glossy` object.
#[derive(serde::Serialize)]
struct GlossyInfo {
    variant: &'static str,
    decomposition: &'static str,
    directions: &'static str,
    rounds: usize,
    fraction: f64,
    importance: String,
    max_links: usize,
    max_bytes: usize,
    transport: TransportOptions,
    image_tolerance: Option<f64>,
    gather_mode: Option<&'static str>,
    gather_rays: usize,
}
