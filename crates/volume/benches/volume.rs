//! Global cube benches (issue 14 §8; GlobalCube §3.1): the CPU projector's compositing
//! throughput against a memory copy of the same bytes, measured in the same run.
//!
//! - `sweep/lounge_32^3_fb8`: one full sweep of the projection (every receiving cell of
//!   `gc-lounge-32`, the standard global cube at level 0, 8² pixels per frustum, exact
//!   sampling, no supersampling, one receiver sample) on all rayon threads. Throughput
//!   in bytes: every composited cell reads its traversal record and the three channel
//!   coefficients of its entry face ([`BYTES_PER_COMPOSITE`]); the number of
//!   composites is counted once before the bench (the projector reports it).
//! - `sweep/memcpy`: a copy of a buffer of the size of the grid's traversal records and
//!   coefficients, repeated to the same total bytes as one sweep — the memory-bound
//!   floor the compositing loop is compared with. The ratio of the two rows' bytes per
//!   second is what docs/performance.md records ("projector / copy").
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use std::time::Duration;
use wavelux_volume::TraversalCell;
use wavelux_volume::VolumeGrid;
use wavelux_volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux_volume::backend::{Emission, FaceRgb, ProjectionScene, Projector, Receiver};
use wavelux_volume::cell::{Collision, depth_of, total_weight};

/// Bytes one composite reads: the cell record and one face's three f64 coefficients.
const BYTES_PER_COMPOSITE: u64 = (std::mem::size_of::<TraversalCell>() + 3 * 8) as u64;

struct Grid {
    side: usize,
    voxel: f64,
    cells: Vec<TraversalCell>,
    map: Vec<u32>,
    coefficients: Vec<FaceRgb>,
    power: Vec<[f64; 3]>,
}

/// `gc-lounge-32` as one traversal cell per voxel, emitting its source (any values
/// cost the same).
fn lounge() -> Grid {
    let scene = wavelux_scene::builtin::builtin("gc-lounge-32").expect("gc-lounge-32 is built in");
    let g = VolumeGrid::from_medium(&scene.media[0]).expect("valid medium");
    let side = g.side;
    let mut cells = Vec::with_capacity(side * side * side);
    let mut coefficients = Vec::with_capacity(side * side * side);
    let mut power = Vec::with_capacity(side * side * side);
    for ((z, y, x), &s) in g.opacity.indexed_iter() {
        let a = depth_of(s);
        cells.push(TraversalCell {
            origin: [x as u32, y as u32, z as u32],
            size: 1,
            extinction: a,
            total_weight: if s > 0.0 {
                total_weight(a, Collision::Exact)
            } else {
                0.0
            },
        });
        let src = [0, 1, 2].map(|c| g.source[c][(z, y, x)]);
        coefficients.push([src; 6]);
        power.push(src);
    }
    let map = (0..cells.len() as u32).collect();
    Grid {
        side,
        voxel: g.voxel,
        cells,
        map,
        coefficients,
        power,
    }
}

fn sweep(c: &mut Criterion) {
    let g = lounge();
    let scene = ProjectionScene {
        side: g.side,
        voxel: g.voxel,
        cells: &g.cells,
        cell_map: &g.map,
    };
    let emission = Emission {
        coefficients: &g.coefficients,
        power: &g.power,
    };
    let receivers: Vec<Receiver> = g
        .cells
        .iter()
        .enumerate()
        .filter(|(_, c)| c.extinction > 0.0)
        .map(|(i, _)| Receiver {
            cell: i as u32,
            framebuffer: 8,
        })
        .collect();
    let cpu = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    let mut out = vec![[[0.0; 3]; 6]; receivers.len()];
    let stats = cpu
        .gather(&scene, &emission, Collision::Exact, &receivers, &mut out)
        .expect("gather");
    let bytes = stats.composited * BYTES_PER_COMPOSITE;
    eprintln!(
        "lounge 32³: {} receivers, {} rays, {} composites ({:.1} per ray), {bytes} bytes per sweep",
        receivers.len(),
        stats.rays,
        stats.composited,
        stats.composited as f64 / stats.rays as f64
    );
    let mut grp = c.benchmark_group("sweep");
    grp.sample_size(10);
    grp.measurement_time(Duration::from_secs(20));
    grp.throughput(Throughput::Bytes(bytes));
    grp.bench_function("lounge_32^3_fb8", |b| {
        b.iter(|| {
            cpu.gather(
                &scene,
                &emission,
                Collision::Exact,
                black_box(&receivers),
                &mut out,
            )
            .expect("gather")
        })
    });
    // The copy: the grid's records and coefficients as bytes, copied until `bytes`.
    let chunk =
        g.cells.len() * (std::mem::size_of::<TraversalCell>() + std::mem::size_of::<FaceRgb>());
    let src = vec![1u8; chunk];
    let mut dst = vec![0u8; chunk];
    let repeats = bytes.div_ceil(chunk as u64);
    grp.throughput(Throughput::Bytes(repeats * chunk as u64));
    grp.bench_function("memcpy", |b| {
        b.iter(|| {
            for _ in 0..repeats {
                dst.copy_from_slice(black_box(&src));
                black_box(&mut dst);
            }
        })
    });
    grp.finish();
}

criterion_group!(benches, sweep);
criterion_main!(benches);
