//! The error estimate of a run: its surface averages against a quick path-traced check
//! (`--samples` per surface), as a relative L1, the check's noise floor and the largest
//! z-score.

use wavelux::render::{PathTracer, ReferenceOptions, SurfaceEstimate};
use wavelux::scene::Scene;

use crate::report;

/// Compares surface averages with a quick path-traced check; `Err` says why the check
/// cannot run (the path tracer rejects the scene or a surface, or the scene reflects
/// no light, so there is nothing to compare relative to).
pub fn estimate_error(
    scene: &Scene,
    surfaces: &[report::SurfaceResult],
    samples: u64,
    opts: &ReferenceOptions,
) -> Result<report::ErrorEstimate, String> {
    let pt = PathTracer::new(scene)
        .map_err(|e| format!("the path tracer cannot trace the scene: {e}"))?;
    compare(surfaces, samples, |i| {
        pt.side_average(i, surfaces[i].side == "back", samples, opts)
            .map_err(|e| e.to_string())
    })
}

/// The error estimate of `surfaces` against per-surface Monte Carlo estimates
/// (`estimate(i)`, `samples` each; `Err` names why surface `i` cannot be sampled).
pub fn compare(
    surfaces: &[report::SurfaceResult],
    samples: u64,
    mut estimate: impl FnMut(usize) -> Result<SurfaceEstimate, String>,
) -> Result<report::ErrorEstimate, String> {
    let (mut num, mut den, mut noise, mut max_z) = (0.0, 0.0, 0.0, 0.0f64);
    for (i, s) in surfaces.iter().enumerate() {
        let est = estimate(i)
            .map_err(|e| format!("the path tracer cannot sample surface {:?}: {e}", s.name))?;
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
    if den.is_nan() || den <= 0.0 {
        return Err("the check found no reflected light to measure the error against".into());
    }
    Ok(report::ErrorEstimate {
        relative_l1: num / den,
        check_noise: noise / den,
        max_z,
        samples,
    })
}
