//! Record and replay of the transfer blocks' shadow rays for a batched occluder
//! (issue 17, "Solver"; the shadow rays are the `V(x, y)` of Ziegler §2.1's kernel).
//!
//! A device such as a GPU answers occlusion queries only in large batches
//! ([`wavelux_geometry::backend::Occluder`]), while a transfer block asks them one at
//! a time, deep inside its quadrature. [`TransferCtx::blocks_seen`] therefore computes
//! a window of blocks three times over:
//!
//! 1. *record*: every block of the window runs with a tape that stores each shadow
//!    ray's query in the block's order and answers "visible"; the far pairs' probe
//!    ([`crate::transfer::FAR_RATIO`]) reports disagreement, so the block's own rays
//!    are recorded after the probe's. The recorded tape is therefore a superset of the
//!    rays the block really shoots, in the same order. Recording skips the exact parts
//!    (the costly closed forms): they need no rays.
//! 2. *answer*: the window's tapes go to the occluder in batches of at most
//!    [`CHUNK_RAYS`] queries;
//! 3. *replay*: every block runs again, each shadow ray taking the answer of the next
//!    equal recorded query at or after the tape's cursor; a ray the tape lacks (a
//!    branch the record pass could not foresee: the 16 fixed rays that weight the
//!    exact parts of a grazing pair whose shaft meets no blocker, 0.07 % of the
//!    Cornell box's block rays at level 2) is answered by
//!    [`wavelux_geometry::Accel::occluded`] itself and counted as deferred.
//!
//! Every answer equals `Accel::occluded` on the same query (the occluder's contract,
//! and equal queries have equal answers), the replay takes the same branches as the
//! direct computation, and the per-block counters are added once, by the replay: the
//! blocks, what their rays saw, and the kernel-evaluation and ray counts are bitwise
//! those of [`TransferCtx::block_seen`], whatever the device, the window and the
//! thread count. A device error moves the batch, and every later block, to the CPU
//! ([`TransferCtx::device_failure`]).

use std::sync::atomic::Ordering;

use rayon::prelude::*;
use wavelux_geometry::Accel;
use wavelux_geometry::backend::{Occluder, OcclusionQuery};

use crate::transfer::{LinkVisibility, Region, TransferCtx};

/// The fake batched occluder shared with `tests/backends.rs`.
#[cfg(test)]
#[path = "../tests/support/fake_occluder.rs"]
mod fake_occluder;

/// Most queries handed to the occluder in one call (2²⁰, issue 17).
pub const CHUNK_RAYS: usize = 1 << 20;

/// Blocks recorded and replayed together: large enough to fill a device batch (about
/// 650 rays per block on the default Cornell box), small enough that the tapes stay
/// near 50 MB (a query is 64 bytes).
pub const WINDOW_BLOCKS: usize = 1024;

/// The shadow rays of one block computation: their count and how they are answered.
#[derive(Debug)]
pub(crate) struct Rays<'t> {
    /// Rays asked so far.
    pub(crate) count: u64,
    tape: Tape<'t>,
}

#[derive(Debug)]
enum Tape<'t> {
    /// Answered at once by the accelerator.
    Direct,
    /// Recorded, answered "visible".
    Record(&'t mut Vec<OcclusionQuery>),
    /// Answered from a recorded tape.
    Replay {
        queries: &'t [OcclusionQuery],
        answers: &'t [bool],
        next: usize,
        missed: u64,
    },
}

impl<'t> Rays<'t> {
    /// Rays answered at once by the accelerator.
    pub(crate) fn direct() -> Self {
        Self {
            count: 0,
            tape: Tape::Direct,
        }
    }

    fn record(tape: &'t mut Vec<OcclusionQuery>) -> Self {
        Self {
            count: 0,
            tape: Tape::Record(tape),
        }
    }

    fn replay(queries: &'t [OcclusionQuery], answers: &'t [bool]) -> Self {
        Self {
            count: 0,
            tape: Tape::Replay {
                queries,
                answers,
                next: 0,
                missed: 0,
            },
        }
    }

    /// Whether this is the record pass (its answers are placeholders).
    pub(crate) fn recording(&self) -> bool {
        matches!(self.tape, Tape::Record(_))
    }

    /// Rays the replay had to answer on the CPU.
    fn missed(&self) -> u64 {
        match self.tape {
            Tape::Replay { missed, .. } => missed,
            _ => 0,
        }
    }

    /// Whether the segment of `q` is unblocked; counts the ray.
    pub(crate) fn visible(&mut self, accel: &Accel, q: OcclusionQuery) -> bool {
        self.count += 1;
        match &mut self.tape {
            Tape::Direct => !accel.occluded(q.p, q.q, q.ignore),
            Tape::Record(tape) => {
                tape.push(q);
                true
            }
            Tape::Replay {
                queries,
                answers,
                next,
                missed,
            } => match queries[*next..].iter().position(|r| *r == q) {
                Some(k) => {
                    let i = *next + k;
                    *next = i + 1;
                    !answers[i]
                }
                None => {
                    *missed += 1;
                    !accel.occluded(q.p, q.q, q.ignore)
                }
            },
        }
    }
}

impl TransferCtx<'_> {
    /// The transfer blocks of many node pairs, `out[i]` that of `pairs[i]`: bitwise
    /// [`Self::block_seen`] of each (module docs). Without an occluder
    /// ([`Self::with_occluder`]) the blocks are computed directly in parallel; with one,
    /// windows of [`WINDOW_BLOCKS`] blocks are recorded, answered in one batch and
    /// replayed.
    pub fn blocks_seen(&self, pairs: &[(Region, Region)]) -> Vec<(Vec<f64>, LinkVisibility)> {
        let mut out = Vec::with_capacity(pairs.len());
        for window in pairs.chunks(WINDOW_BLOCKS) {
            match self.occluder() {
                None => out.par_extend(window.par_iter().map(|(r, e)| self.block_seen(r, e))),
                Some(occ) => out.extend(self.window_on(occ, window)),
            }
        }
        out
    }

    /// One window through record, answer and replay.
    fn window_on(
        &self,
        occ: &dyn Occluder,
        window: &[(Region, Region)],
    ) -> Vec<(Vec<f64>, LinkVisibility)> {
        let tapes: Vec<Vec<OcclusionQuery>> = window
            .par_iter()
            .map(|(r, e)| {
                let mut tape = Vec::new();
                self.block_with(r, e, &mut Rays::record(&mut tape));
                tape
            })
            .collect();
        let mut offsets = Vec::with_capacity(tapes.len() + 1);
        offsets.push(0);
        for t in &tapes {
            offsets.push(offsets.last().copied().unwrap_or(0) + t.len());
        }
        let queries: Vec<OcclusionQuery> = tapes.concat();
        drop(tapes);
        let mut answers = vec![false; queries.len()];
        for (q, a) in queries
            .chunks(CHUNK_RAYS)
            .zip(answers.chunks_mut(CHUNK_RAYS))
        {
            self.answer(occ, q, a);
        }
        let done: Vec<(Vec<f64>, LinkVisibility, u64)> = window
            .par_iter()
            .enumerate()
            .map(|(i, (r, e))| {
                let (a, b) = (offsets[i], offsets[i + 1]);
                let mut rays = Rays::replay(&queries[a..b], &answers[a..b]);
                let (block, seen) = self.block_with(r, e, &mut rays);
                (block, seen, rays.missed())
            })
            .collect();
        let missed: u64 = done.iter().map(|d| d.2).sum();
        self.deferred_rays.fetch_add(missed, Ordering::Relaxed);
        done.into_iter().map(|(b, s, _)| (b, s)).collect()
    }

    /// Answers one batch on the occluder; on a device error, on the CPU, and the
    /// occluder is dropped for the rest of the run.
    fn answer(&self, occ: &dyn Occluder, q: &[OcclusionQuery], out: &mut [bool]) {
        match occ.occluded_queries(q, out) {
            Ok(s) => {
                self.device_rays
                    .fetch_add(s.device_rays as u64, Ordering::Relaxed);
                self.deferred_rays
                    .fetch_add(s.deferred_rays as u64, Ordering::Relaxed);
            }
            Err(e) => {
                self.fail_device(e.to_string());
                out.par_iter_mut()
                    .zip(q.par_iter())
                    .for_each(|(o, qu)| *o = self.accel().occluded(qu.p, qu.q, qu.ignore));
                self.deferred_rays
                    .fetch_add(q.len() as u64, Ordering::Relaxed);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::Ordering;

    use super::fake_occluder::FakeOccluder;
    use super::*;
    use crate::hierarchy::{self, LinkRec};
    use crate::{BasisKind, Prepared, SolverConfig};

    fn same(a: &[LinkRec], b: &[LinkRec]) {
        assert_eq!(a.len(), b.len());
        for (x, y) in a.iter().zip(b) {
            assert_eq!((x.r, x.e, x.seen), (y.r, y.e, y.seen));
            assert!(
                x.block
                    .iter()
                    .zip(&y.block)
                    .all(|(u, v)| u.to_bits() == v.to_bits())
                    && x.block.len() == y.block.len(),
                "{:?} {:?}",
                x.r,
                x.e
            );
        }
    }

    /// Refinement of the Cornell box (M2, far-pair probes on, several windows) with
    /// its blocks recorded, answered by an occluder in batches and replayed gives
    /// bitwise the links, blocks, visibility classes, ray and kernel-evaluation
    /// counts of the direct computation; the replay answers almost every ray from
    /// the tape; a device failing mid-run changes nothing but moves the rest to the
    /// CPU.
    #[test]
    fn replayed_blocks_are_bitwise_the_direct_ones() {
        let scene = wavelux_scene::builtin::cornell_box();
        let cfg = SolverConfig {
            basis: BasisKind::Multiwavelet(2),
            far_probe_points: Some(2),
            max_level: 1,
            eps: 2e-3,
            ..SolverConfig::default()
        };
        let prep = Prepared::new(&scene, &cfg).unwrap();
        let params = prep.refine_params(cfg.eps);
        let direct = prep.transfer().unwrap();
        let (a, ca) = hierarchy::refine_all(&direct, &params, &|_| 1.0);
        assert!(a.len() > 2 * WINDOW_BLOCKS, "{} links", a.len());
        let counters = |c: &TransferCtx<'_>| {
            (
                c.rays.load(Ordering::Relaxed),
                c.kernel_evals.load(Ordering::Relaxed),
            )
        };
        for fail_from in [usize::MAX, 1] {
            let fake = FakeOccluder::new(&prep.accel, fail_from);
            let ctx = prep.transfer().unwrap().with_occluder(&fake);
            let (b, cb) = hierarchy::refine_all(&ctx, &params, &|_| 1.0);
            same(&a, &b);
            assert_eq!(ca, cb);
            assert_eq!(counters(&direct), counters(&ctx));
            let (rays, dev, def) = (
                ctx.rays.load(Ordering::Relaxed),
                ctx.device_rays.load(Ordering::Relaxed),
                ctx.deferred_rays.load(Ordering::Relaxed),
            );
            println!(
                "fail_from {fail_from}: {} links, {rays} rays, device {dev}, deferred {def}, failure {:?}",
                b.len(),
                ctx.device_failure()
            );
            if fail_from == usize::MAX {
                assert!(ctx.device_failure().is_none());
                assert!(dev > 0 && def * 100 <= dev, "device {dev}, deferred {def}");
            } else {
                assert!(ctx.device_failure().is_some_and(|m| m.contains("lost")));
                assert!(!ctx.batches_blocks());
            }
        }
    }
}
