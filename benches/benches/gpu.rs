//! wavelux-gpu benches (issue 17): GPU against CPU in the same run.
//!
//! - `occlusion/soup_100k`: 2¹⁶ shadow rays between random points of a 100 000-triangle
//!   soup (10×10×10 box, triangles of edge ≲ 0.3); `cpu` is `Accel::occluded_queries`
//!   on all rayon threads, `gpu` the device occluder end to end (upload of the queries,
//!   kernel, read-back, CPU re-trace of unsure rays). The unsure fraction is printed.
//! - `matvec/bsr9x9` (2 000 block rows, ~20 blocks each) and `matvec/dense` (2 048²):
//!   one product, `cpu` the f64 reference, `gpu` the device; throughput in stored
//!   entries.
//!
//! - `cube/64^3_rR` (R = 16, 32, 64): the global cube's projection of 64 receivers in a
//!   64³ grid of thin random medium (optical depth 0.005–0.05 per voxel, so rays cross
//!   the grid), `cpu` the CPU projector (exact sampling, no supersampling: the same
//!   work) on all rayon threads, `gpu` [`wavelux::gpu::GpuProjector`] end to end
//!   (upload of grid and emission, kernel, read-back); throughput in receiver faces.
//!
//! Without an adapter the GPU rows print `SKIPPED: no wgpu adapter` and only the CPU
//! rows run. On a software adapter (Mesa lavapipe) the ratios say nothing about GPU
//! speed; docs/performance.md records which adapter produced a number.
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::hint::black_box;
use wavelux::geometry::backend::OcclusionBackend;
use wavelux::geometry::{Accel, OcclusionQuery, Primitive, Triangle};
use wavelux::gpu::{Gpu, GpuMatVec, GpuOcclusion, GpuProjector};
use wavelux::linear::backend::{Bsr, CpuMatVec, MatVecBackend, Matrix};
use wavelux::volume::TraversalCell;
use wavelux::volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux::volume::backend::{Emission, FaceRgb, ProjectionScene, Projector, Receiver};
use wavelux::volume::cell::{Collision, total_weight};

fn gpu() -> Option<std::sync::Arc<Gpu>> {
    match Gpu::new() {
        Ok(g) => {
            let a = g.adapter();
            eprintln!(
                "gpu bench adapter: {} ({}, {}, {})",
                a.name, a.device_type, a.backend, a.driver
            );
            Some(g)
        }
        Err(e) => {
            eprintln!("SKIPPED: no wgpu adapter ({e})");
            None
        }
    }
}

fn rv(r: &mut Pcg64, lo: f64, hi: f64) -> DVec3 {
    DVec3::new(
        r.random_range(lo..hi),
        r.random_range(lo..hi),
        r.random_range(lo..hi),
    )
}

fn occlusion(c: &mut Criterion) {
    let mut r = Pcg64::seed_from_u64(1);
    let prims: Vec<Primitive> = (0..100_000)
        .filter_map(|_| {
            let p = rv(&mut r, 0.0, 10.0);
            Triangle::new(p, p + rv(&mut r, -0.3, 0.3), p + rv(&mut r, -0.3, 0.3))
                .ok()
                .map(Primitive::from)
        })
        .collect();
    let acc = Accel::build(prims).expect("finite soup");
    let qs: Vec<OcclusionQuery> = (0..1 << 16)
        .map(|_| OcclusionQuery {
            p: rv(&mut r, 0.0, 10.0),
            q: rv(&mut r, 0.0, 10.0),
            ignore: [None, None],
        })
        .collect();
    let mut out = vec![false; qs.len()];
    let mut g = c.benchmark_group("occlusion/soup_100k");
    g.sample_size(10);
    g.throughput(Throughput::Elements(qs.len() as u64));
    g.bench_function("cpu", |b| {
        b.iter(|| {
            acc.occluded_queries(black_box(&qs), &mut out)
                .expect("lengths")
        })
    });
    if let Some(dev) = gpu() {
        let occ = GpuOcclusion::new(dev).occluder(&acc).expect("upload");
        let stats = occ.occluded_queries(&qs, &mut out).expect("device");
        eprintln!(
            "occlusion/soup_100k: unsure {} of {} ({:.3} %)",
            stats.deferred_rays,
            stats.queries,
            100.0 * stats.deferred_rays as f64 / stats.queries as f64
        );
        g.bench_function("gpu", |b| {
            b.iter(|| {
                occ.occluded_queries(black_box(&qs), &mut out)
                    .expect("device")
            })
        });
    }
    g.finish();
}

fn matvec(c: &mut Criterion) {
    let mut r = Pcg64::seed_from_u64(2);
    let (nbr, per_row) = (2000usize, 20usize);
    let mut row_ptr = vec![0];
    let mut col_idx = Vec::new();
    for _ in 0..nbr {
        let mut cols: Vec<usize> = (0..per_row).map(|_| r.random_range(0..nbr)).collect();
        cols.sort_unstable();
        cols.dedup();
        col_idx.extend(cols);
        row_ptr.push(col_idx.len());
    }
    let values = (0..col_idx.len() * 81)
        .map(|_| r.random_range(-1.0..1.0))
        .collect();
    let bsr = Matrix::BlockSparse(
        Bsr::new((9, 9), (nbr, nbr), row_ptr, col_idx, values).expect("valid BSR"),
    );
    let n = 2048;
    let dense = Matrix::dense(
        n,
        n,
        (0..n * n).map(|_| r.random_range(-1.0..1.0)).collect(),
    )
    .expect("valid dense");
    let dev = gpu();
    for (name, m) in [("bsr9x9", &bsr), ("dense", &dense)] {
        let x: Vec<f64> = (0..m.cols()).map(|_| r.random_range(-1.0..1.0)).collect();
        let mut y = vec![0.0; m.rows()];
        let mut g = c.benchmark_group(format!("matvec/{name}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(m.stored_values().len() as u64));
        let cpu = CpuMatVec.prepare(m).expect("cpu");
        g.bench_function("cpu", |b| {
            b.iter(|| cpu.apply(1, black_box(&x), &mut y).expect("cpu"))
        });
        if let Some(d) = &dev {
            let p = GpuMatVec::new(d.clone()).prepare(m).expect("upload");
            g.bench_function("gpu", |b| {
                b.iter(|| p.apply(1, black_box(&x), &mut y).expect("gpu"))
            });
        }
        g.finish();
    }
}

fn cube(c: &mut Criterion) {
    let mut r = Pcg64::seed_from_u64(3);
    let side = 64usize;
    let n3 = side * side * side;
    let cells: Vec<TraversalCell> = (0..n3)
        .map(|i| {
            let k = r.random_range(0.005..0.05);
            TraversalCell {
                origin: [
                    (i % side) as u32,
                    ((i / side) % side) as u32,
                    (i / (side * side)) as u32,
                ],
                size: 1,
                extinction: k,
                total_weight: total_weight(k, Collision::Exact),
            }
        })
        .collect();
    let map: Vec<u32> = (0..n3 as u32).collect();
    let coefficients: Vec<FaceRgb> = (0..n3)
        .map(|_| [[r.random_range(0.0..1.0), 0.5, 0.25]; 6])
        .collect();
    let power = vec![[0.0; 3]; n3];
    let scene = ProjectionScene {
        side,
        voxel: 1.0 / side as f64,
        cells: &cells,
        cell_map: &map,
    };
    let emission = Emission {
        coefficients: &coefficients,
        power: &power,
    };
    let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    let dev = gpu().map(GpuProjector::new);
    for fb in [16u32, 32, 64] {
        let receivers: Vec<Receiver> = (0..64)
            .map(|_| Receiver {
                cell: r.random_range(0..n3 as u32),
                framebuffer: fb,
            })
            .collect();
        let mut out = vec![[[0.0; 3]; 6]; receivers.len()];
        let mut g = c.benchmark_group(format!("cube/64^3_r{fb}"));
        g.sample_size(10);
        g.throughput(Throughput::Elements(6 * receivers.len() as u64));
        g.bench_function("cpu", |b| {
            b.iter(|| {
                cpu.gather(
                    &scene,
                    &emission,
                    Collision::Exact,
                    black_box(&receivers),
                    &mut out,
                )
                .expect("cpu")
            })
        });
        if let Some(p) = &dev {
            g.bench_function("gpu", |b| {
                b.iter(|| {
                    p.gather(
                        &scene,
                        &emission,
                        Collision::Exact,
                        black_box(&receivers),
                        &mut out,
                    )
                    .expect("gpu")
                })
            });
        }
        g.finish();
    }
}

criterion_group!(benches, occlusion, matvec, cube);
criterion_main!(benches);
