//! `--method reference`: the Monte Carlo path tracer over the exact geometry — surface
//! averages with standard errors (`--samples` per surface) and a path-traced image.

use std::time::Instant;

use anyhow::{Context, bail};
use wavelux::render::PathTracer;

use super::{Job, Method, Outcome, reported_back, secs, surface_result};
use crate::cli::SolveArgs;
use crate::progress;
use crate::report;

/// The path tracer.
struct Reference;

/// The reference plan; it needs `--samples >= 1`.
pub fn plan(a: &SolveArgs) -> anyhow::Result<Box<dyn Method>> {
    if a.samples == 0 {
        bail!("--method reference needs --samples >= 1");
    }
    Ok(Box::new(Reference))
}

impl Method for Reference {
    fn info(&self, base: report::MethodInfo) -> report::MethodInfo {
        report::MethodInfo {
            name: "reference".into(),
            ..base
        }
    }

    fn run(&self, job: &Job<'_>, stats: &mut report::Statistics) -> anyhow::Result<Outcome> {
        let (scene, a) = (job.scene, job.args);
        let t = Instant::now();
        let pt = PathTracer::new(scene)?;
        let pb = progress::bar(
            job.show_progress,
            scene.surfaces.len() as u64,
            "path tracing",
        );
        let mut surfaces = Vec::with_capacity(scene.surfaces.len());
        for i in 0..scene.surfaces.len() {
            let back = reported_back(scene, i);
            let est = pt
                .side_average(i, back, a.samples, &job.reference)
                .with_context(|| format!("surface {:?}", scene.surfaces[i].name))?;
            surfaces.push(surface_result(
                scene,
                i,
                back,
                est.mean,
                Some(est.std_error),
            ));
            pb.inc(1);
        }
        pb.finish_and_clear();
        stats.time_s.monte_carlo = secs(t.elapsed());
        let mut image = None;
        if let Some(view) = job.view {
            let t = Instant::now();
            let pb = progress::bar(job.show_progress, view.height as u64, "rendering");
            let img = pt.render(view, a.spp, &job.reference, &|k| pb.inc(k))?;
            pb.finish_and_clear();
            stats.primary_rays = (view.width * view.height * a.spp * a.spp) as u64;
            stats.time_s.render = secs(t.elapsed());
            image = Some(img);
        }
        Ok(Outcome {
            surfaces,
            error_estimate: None,
            error_estimate_skipped: None,
            warnings: Vec::new(),
            image,
            solution: None,
        })
    }

    fn describe(&self, r: &report::Result) -> String {
        format!(
            "Monte Carlo path tracer, {} samples per surface",
            r.method.samples
        )
    }
}
