//! `--method meshless`: the meshless hierarchical basis with precomputed
//! direct-to-indirect transfer (Meshless §2–§3). One frame lit by the scene's punctual
//! lights and its area emitters: precompute `T` and `S` (or read them from
//! `--transfer`), project the direct irradiance at the sender points (`e = P†E←`),
//! `i = S·e` on the CPU backend (or the GPU's with `--device`), and show `E + ρ(E_dir + n·i)` ([`MeshlessField`]).
//! Surface averages come from the field on a tessellation of the exact primitives
//! (`export::field_surface_averages`), so the path-traced error check applies as for
//! every other method.

use std::time::Instant;

use anyhow::{Context, bail};
use wavelux::meshless::{
    DirectLighting, LinkThreshold, MeshlessConfig, PrecomputeStats, Precomputed, Relighter,
    SceneSurfaces, scene_hash,
};
use wavelux::render::{Component, IndirectSource, MeshlessField, RenderOptions};
use wavelux::scene::Scene;

use super::{Job, Method, Outcome, error_check, output, secs, surface_result, warnings};
use crate::cli::{LinkThresholdArg, SolveArgs};
use crate::progress;
use crate::report;
use crate::report::WarningInfo;

/// Default link threshold ε of the CLI (ours). The seed's 0.025 (§4.2) with our
/// dimensionless link norm keeps ~15 % of the Cornell box's indirect light (relative L1
/// of the surface averages 42 % against the path tracer, 3 levels); 0.005 gives 7 %
/// and ε = 0 4 % at 6× the time of 0.005.
const DEFAULT_EPS: f64 = 0.005;

/// Samples per surface of the surface averages (midpoint rule on a tessellation).
pub const AVERAGE_SAMPLES: usize = 256;

/// The meshless method with its configuration.
struct Meshless {
    config: MeshlessConfig,
}

/// The meshless plan: the knobs of `--levels`, `--sender-levels`, `--r-coarse`,
/// `--gather-rays`, `--eps` (the link threshold ε, default [`DEFAULT_EPS`]), `--bounces`,
/// `--bounce-eps`, `--link-threshold`, `--max-dropped-share`, `--viewpoint`, `--skip`, `--max-points`, `--max-links` and `--seed`,
/// checked by [`MeshlessConfig::validate`].
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    Ok(Box::new(Meshless { config: config(a)? }))
}

/// The configuration of the arguments (see [`plan`]).
pub fn config(a: &SolveArgs) -> anyhow::Result<MeshlessConfig> {
    let m = &a.meshless;
    let viewpoint = match m.viewpoint.as_deref() {
        None => None,
        Some([x, y, z]) => Some([*x, *y, *z]),
        Some(_) => bail!("--viewpoint needs three comma-separated numbers x,y,z"),
    };
    if m.emitter_samples == 0 {
        bail!("--emitter-samples must be >= 1");
    }
    let config = MeshlessConfig {
        receiver_levels: m.levels.unwrap_or(6),
        sender_levels: m.sender_levels,
        r_coarse: m.r_coarse,
        gather_rays: m.gather_rays,
        epsilon: a.eps.unwrap_or(DEFAULT_EPS),
        bounce_epsilon: m.bounce_eps,
        threshold: match m.link_threshold {
            LinkThresholdArg::SenderArea => LinkThreshold::SenderArea,
            LinkThresholdArg::Uniform => LinkThreshold::Uniform,
        },
        max_dropped_share: m
            .max_dropped_share
            .or(MeshlessConfig::default().max_dropped_share),
        bounces: m.bounces,
        seed: a.seed,
        viewpoint,
        max_points: m.max_points,
        max_links: m.max_links,
        skip: m.skip,
        ..MeshlessConfig::default()
    };
    config.validate().context("--method meshless")?;
    Ok(config)
}

impl Method for Meshless {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        report::MethodInfo {
            name: "meshless".into(),
            eps: Some(self.config.epsilon),
            meshless: Some(self.config.clone()),
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let (scene, a) = (job.scene, job.args);
        let t = Instant::now();
        let query = SceneSurfaces::new(scene).context("meshless scene query")?;
        let (pre, loaded) = precompute(scene, a, &self.config, job.show_progress)?;
        stats.time_s.setup = secs(t.elapsed());

        let t = Instant::now();
        let mut parts = Vec::new();
        if !scene.lights.is_empty() {
            parts.push(DirectLighting::Lights(scene.lights.clone()));
        }
        if query.has_emitters() {
            parts.push(DirectLighting::Emitters {
                samples: a.meshless.emitter_samples,
                seed: a.seed,
            });
        }
        let direct = DirectLighting::Sum(parts);
        let relighter = Relighter::new(&pre, super::device::DeviceTransfer::new(job.device))?;
        let indirect = relighter
            .relight_with(&query, &direct)
            .context("meshless relighting")?;
        stats.time_s.solve = secs(t.elapsed());
        let field = MeshlessField::new(
            &query,
            IndirectSource::Hierarchical(&indirect),
            direct,
            Component::Full,
        );

        let averages =
            wavelux::render::export::field_surface_averages(&field, scene, AVERAGE_SAMPLES)?;
        let surfaces: Vec<report::SurfaceResult> = averages
            .iter()
            .enumerate()
            .map(|(i, b)| surface_result(scene, i, false, *b, None))
            .collect();
        let mut check = Err("--samples 0".to_string());
        let mut warned = unsampled_emitters(&query, &a.scene);
        if a.samples > 0 {
            let t = Instant::now();
            let sp = progress::spinner(job.show_progress, "Monte Carlo error check");
            check = error_check::estimate_error(scene, &surfaces, a.samples, &job.reference);
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
            let (img, rs) = wavelux::render::render(
                &field,
                view,
                &RenderOptions {
                    spp: a.spp,
                    // The field already integrates the direct light per point with
                    // exact shadow rays; a final gather would lose punctual lights.
                    gather: 0,
                    // Likewise for exact direct light from emitters.
                    direct: 0,
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
        if let Some(g) = &a.gltf {
            wavelux::render::export::write_field_gltf(&field, scene, g)
                .with_context(|| format!("glTF export to {g:?}"))?;
        }
        if let Some(res) = a.lightmaps {
            let dir = output::lightmaps_dir(a, job.stem);
            wavelux::render::export::write_field_lightmaps(&field, scene, &dir, res)?;
        }

        let s = &pre.stats;
        stats.elements = pre.basis.len();
        stats.links = pre.s.nnz();
        stats.solver_rays = s.rays;
        stats.solver_bytes = s.basis_bytes + s.s_bytes;
        stats.time_s.refine = (s.placement_ms + s.refine_ms + s.bounce_ms) * 1e-3;
        stats.meshless = Some(report::MeshlessStats {
            transfer_loaded: loaded,
            backend: relighter.backend_name(),
            frame: indirect.times,
            precompute: reported_stats(&pre),
            scene_hash: format!("{:016x}", pre.scene_hash),
        });
        Ok(Outcome {
            surfaces,
            error_estimate,
            image,
            solution: None,
            error_estimate_skipped,
            warnings: warned,
        })
    }

    /// The relighting product `S·e` runs on the GPU (`wavelux_gpu::GpuTransfer`); the
    /// precomputation stays on the CPU.
    fn gpu_kernel(&self) -> Result<(), String> {
        Ok(())
    }

    fn describe(&self, r: &report::Result) -> String {
        let c = &self.config;
        let mut s = format!(
            "meshless hierarchical basis, {} receiver / {} sender levels, eps {:e}, {} bounces, {} gather rays",
            c.receiver_levels, c.sender_levels, c.epsilon, c.bounces, c.gather_rays
        );
        if let Some(m) = &r.statistics.meshless {
            let pts: usize = m.precompute.points_per_level.iter().sum();
            s.push_str(&format!(
                ", {pts} points, {} links in S{}",
                r.statistics.links,
                if m.transfer_loaded {
                    " (transfer loaded)"
                } else {
                    ""
                }
            ));
        }
        s
    }
}

/// Area emitters that the meshless direct lighting cannot sample (neither a triangle
/// nor a parallelogram): a `not-modelled` warning each, naming the emitter.
pub fn unsampled_emitters(query: &SceneSurfaces, file: &str) -> Vec<WarningInfo> {
    query
        .unsampled_emitters()
        .iter()
        .map(|name| WarningInfo {
            kind: "not-modelled".into(),
            file: Some(file.into()),
            element: format!("emitter {name:?}"),
            message: format!(
                "{file}: emitter {name:?}: only triangle and parallelogram emitters are \
                 sampled by --method meshless: its direct light is skipped"
            ),
            use_method: None,
        })
        .collect()
}

/// The precomputed transfer: read from `--transfer` when that file exists (it must
/// belong to this scene), else built (and written to `--transfer` when given).
/// Returns whether it was loaded.
pub fn precompute(
    scene: &Scene,
    a: &SolveArgs,
    config: &MeshlessConfig,
    show_progress: bool,
) -> anyhow::Result<(Precomputed, bool)> {
    if let Some(path) = &a.meshless.transfer
        && path.exists()
    {
        let pre = Precomputed::load(path, scene_hash(scene))?;
        if &pre.config != config {
            bail!(
                "the transfer in {path:?} was precomputed with other meshless options; \
                 delete it or pass the options it was built with"
            );
        }
        return Ok((pre, true));
    }
    let pb = progress::spinner(show_progress, "meshless precomputation");
    let pre = Precomputed::build(scene, config, &|phase, done, total| {
        pb.set_message(format!("meshless {phase} {done}/{total}"));
    })?;
    pb.finish_and_clear();
    if let Some(path) = &a.meshless.transfer {
        pre.save(path)?;
    }
    Ok((pre, false))
}

/// The precomputation's statistics as the JSON reports them: without
/// `pre.stats.warnings`, which repeat what `warnings::unmodelled` and
/// [`unsampled_emitters`] already report once, with file and element, in the run's
/// top-level `warnings`.
pub(super) fn reported_stats(pre: &Precomputed) -> PrecomputeStats {
    PrecomputeStats {
        warnings: Vec::new(),
        ..pre.stats.clone()
    }
}
