//! The error estimate of a run: its surface averages against a quick path-traced check
//! (`--samples` per surface), as a relative L1, the check's noise floor and the largest
//! z-score.

use wavelux::render::{PathTracer, ReferenceOptions};
use wavelux::scene::Scene;

use crate::report;

/// Compares surface averages with a quick path-traced check; `None` when the check
/// cannot run or the scene reflects nothing.
pub fn estimate_error(
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
