//! A fake batched occluder for the tests of record and replay (issue 17, "Solver"):
//! it answers every batch on the CPU accelerator and claims every ray for its
//! "device", or fails with a backend error (message "device lost") from its
//! `fail_from`-th batch on. Shared by `replay.rs`'s unit test and `tests/backends.rs`
//! (included with `#[path]`), so the two exercise the same device behaviour.

use std::sync::atomic::{AtomicUsize, Ordering};

use wavelux_geometry::backend::{Occluder, OcclusionQuery, OcclusionStats};
use wavelux_geometry::{Accel, GeometryError};

/// Answers as `accel` and claims every ray for its device, or fails from the
/// `fail_from`-th batch on (0-based; `usize::MAX`: never).
pub struct FakeOccluder<'a> {
    accel: &'a Accel,
    batches: AtomicUsize,
    fail_from: usize,
}

impl<'a> FakeOccluder<'a> {
    /// A fake device over `accel` that fails from batch `fail_from` on.
    pub fn new(accel: &'a Accel, fail_from: usize) -> Self {
        Self {
            accel,
            batches: AtomicUsize::new(0),
            fail_from,
        }
    }
}

impl Occluder for FakeOccluder<'_> {
    fn occluded_queries(
        &self,
        q: &[OcclusionQuery],
        out: &mut [bool],
    ) -> Result<OcclusionStats, GeometryError> {
        if self.batches.fetch_add(1, Ordering::Relaxed) >= self.fail_from {
            return Err(GeometryError::Backend {
                device: "fake".into(),
                message: "device lost".into(),
            });
        }
        self.accel.occluded_queries(q, out)?;
        Ok(OcclusionStats {
            queries: q.len(),
            device_rays: q.len(),
            deferred_rays: 0,
        })
    }
}
