//! Meshless benches (issue 15, Meshless §3.3, §4.1): on `atrium-s` with a reduced
//! precomputation (3 receiver / 2 sender levels, 64 gather rays, ε = 0.005):
//! - `precompute`: point placement, refinement of `T` and the bounces of `S`;
//! - `relight`: one frame with the scene's spot (direct irradiance by shadow rays at
//!   the sender points, pull-push, `S·e`);
//! - `apply`: the CPU backend's `S·e` (f32 row-block CSC, active senders only) against
//!   the floor, a plain parallel f32 CSR mat-vec over the same links (same nnz, same
//!   nine values per link, every sender active);
//! - `flatten`: resampling the solution into the one-level basis (§4.1).
//!
//! The targets (precompute of `atrium` at the defaults under 2 minutes, a
//! frame under 20 ms) are reported in docs/performance.md from these numbers and
//! meshless-table1's. Times are the CPU time of the bench process
//! ([`wavelux_benches::cpu_time`]), not wall time; run with `RAYON_NUM_THREADS=1` for
//! the time of one core. The configuration takes the crate's defaults otherwise
//! (the level-0 dropped share ≤ 0.05 since session 29).
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use rayon::prelude::*;
use std::hint::black_box;
use std::time::Duration;
use wavelux::meshless::{
    CpuBackend, FlattenOperator, MeshlessConfig, Precomputed, Relighter, SceneSurfaces,
    TransferBackend, TransferMatrix,
};
use wavelux::scene::Scene;
use wavelux::scene::builtin::builtin;
use wavelux_benches::cpu_time::{CpuTime, cpu_time};

fn setup() -> (Scene, MeshlessConfig) {
    let scene = builtin("atrium-s").expect("atrium-s is built in");
    let cfg = MeshlessConfig {
        receiver_levels: 3,
        sender_levels: 2,
        gather_rays: 64,
        epsilon: 0.005,
        ..MeshlessConfig::default()
    };
    (scene, cfg)
}

/// `S` as plain CSR in f32: row pointers, sender indices, nine values per link.
struct PlainCsr {
    ptr: Vec<u32>,
    col: Vec<u32>,
    val: Vec<f32>,
}

impl PlainCsr {
    fn new(s: &TransferMatrix) -> Self {
        let mut ptr = vec![0u32];
        let (mut col, mut val) = (Vec::new(), Vec::new());
        for i in 0..s.rows() {
            let (c, v) = s.row(i);
            col.extend_from_slice(c);
            for l in v {
                val.extend(l.iter().map(|x| *x as f32));
            }
            ptr.push(col.len() as u32);
        }
        Self { ptr, col, val }
    }

    /// `out = S·e` row by row (the floor: no blocks, no skipping).
    fn apply(&self, e: &[f32], out: &mut [f32]) {
        out.par_chunks_mut(9).enumerate().for_each(|(i, o)| {
            let mut acc = [0f32; 9];
            for k in self.ptr[i] as usize..self.ptr[i + 1] as usize {
                let j = self.col[k] as usize;
                let v = &self.val[k * 9..k * 9 + 9];
                for q in 0..9 {
                    acc[q] += v[q] * e[j * 3 + q / 3];
                }
            }
            o.copy_from_slice(&acc);
        });
    }
}

fn meshless(c: &mut Criterion<CpuTime>) {
    let (scene, cfg) = setup();
    let mut g = c.benchmark_group("meshless/atrium-s");
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(20));
    g.bench_function("precompute", |b| {
        b.iter(|| black_box(Precomputed::build(&scene, &cfg, &|_, _, _| {}).expect("builds")))
    });
    g.finish();

    let pre = Precomputed::build(&scene, &cfg, &|_, _, _| {}).expect("builds");
    let query = SceneSurfaces::new(&scene).expect("query");
    let relighter = Relighter::new(&pre, CpuBackend).expect("cpu backend");
    eprintln!(
        "atrium-s: {} functions ({} senders), {} links in T, {} in S",
        pre.basis.len(),
        pre.senders(),
        pre.t.nnz(),
        pre.s.nnz()
    );
    let mut g = c.benchmark_group("meshless/atrium-s");
    g.sample_size(20);
    g.bench_function("relight", |b| {
        b.iter(|| black_box(relighter.relight(&query, &scene.lights).expect("relights")))
    });

    // apply vs the plain CSR floor, every sender active.
    let e: Vec<f32> = (0..pre.senders() * 3)
        .map(|k| 0.5 + ((k * 7919) % 101) as f32 / 101.0)
        .collect();
    let prepared = CpuBackend.prepare(&pre.s).expect("packs");
    let plain = PlainCsr::new(&pre.s);
    let mut out = vec![0f32; pre.s.rows() * 9];
    g.throughput(Throughput::Elements(pre.s.nnz() as u64));
    g.bench_function("apply/cpu-backend", |b| {
        b.iter(|| {
            CpuBackend.apply(&prepared, &e, &mut out).expect("applies");
            black_box(&out);
        })
    });
    g.bench_function("apply/plain-csr", |b| {
        b.iter(|| {
            plain.apply(&e, &mut out);
            black_box(&out);
        })
    });

    let ind = relighter.relight(&query, &scene.lights).expect("relights");
    let op = FlattenOperator::new(&pre.basis);
    g.throughput(Throughput::Elements(pre.basis.len() as u64));
    g.bench_function("flatten", |b| b.iter(|| black_box(ind.flatten(&op))));
    g.finish();
}

criterion_group! {
    name = benches;
    config = cpu_time();
    targets = meshless
}
criterion_main!(benches);
