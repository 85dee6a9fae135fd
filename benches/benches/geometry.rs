//! Geometry benches: occlusion rays per second through `wavelux-geometry`'s `Accel`
//! (f64 exact tests, `ignore` ids, scale-aware epsilons) against obvhs called directly
//! (f32 Möller–Trumbore in the traversal callback) on the same BVH preset and the same
//! rays, with 1 and 2 rayon threads, in a ~100k-triangle room and a ~1M-triangle scene.
//! The ratio `wrapper / obvhs` of the times is the wrapper's overhead.
//! `wrapper` is `Accel::occluded_queries` (batches of `COHERENT_MIN` or more answered in
//! a coherent order); `wrapper_input_order` answers the same queries one by one in
//! their own order through `Accel::occluded`, as the obvhs variants do, so the two
//! show what the coherent order gains.
//! `obvhs_direct` looks triangles up through `primitive_indices` (obvhs's basic
//! example); `obvhs_leaf_ordered` reorders them into leaf order first (its
//! cornell_box example), the layout the wrapper uses. `occlusion_room_exact` times the
//! wrapper alone on exact primitives (parallelograms, spheres and tori as trimmed
//! patches).
#![allow(missing_docs)] // reason: criterion's macros generate undocumented items

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::{DVec3, Vec3A};
use obvhs::BvhBuildParams;
use obvhs::cwbvh::builder::build_cwbvh_from_tris;
use obvhs::ray::Ray as FRay;
use obvhs::triangle::Triangle as FTri;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use std::sync::Arc;
use std::time::{Duration, Instant};
use wavelux::param as wparam;
use wavelux_benches::{queries, room, scene_big, scene_room};
use wavelux_geometry::{Accel, OcclusionQuery, Primitive, Triangle, TrimmedPatch};

fn f3(v: DVec3) -> Vec3A {
    Vec3A::new(v.x as f32, v.y as f32, v.z as f32)
}

fn bench_scene(c: &mut Criterion, name: &str, tris: Vec<[DVec3; 3]>, n_rays: usize) {
    let mut r = Pcg64::seed_from_u64(7);
    let qs = queries(&tris, n_rays, &mut r);

    let t0 = Instant::now();
    let prims: Vec<Primitive> = tris
        .iter()
        .map(|t| Primitive::Triangle(Triangle { v: *t }))
        .collect();
    let acc = Accel::build(prims).expect("valid scene");
    let t_ours = t0.elapsed();
    let ftris: Vec<FTri> = tris
        .iter()
        .map(|t| FTri {
            v0: f3(t[0]),
            v1: f3(t[1]),
            v2: f3(t[2]),
        })
        .collect();
    let t0 = Instant::now();
    let bvh = build_cwbvh_from_tris(
        &ftris,
        BvhBuildParams::medium_build(),
        &mut Duration::default(),
    );
    let t_obvhs = t0.elapsed();
    eprintln!(
        "{name}: {} triangles; build: wrapper {t_ours:?}, obvhs {t_obvhs:?}",
        tris.len()
    );

    let mut out = vec![false; qs.len()];
    acc.occluded_queries(&qs, &mut out).expect("lengths match");
    let occluded = out.iter().filter(|&&b| b).count();
    eprintln!("{name}: {occluded} of {} shadow rays occluded", qs.len());

    let direct = |q: &OcclusionQuery| {
        let d = q.q - q.p;
        let len = d.length();
        let ray = FRay::new(
            f3(q.p),
            f3(d / len),
            (1e-4 * len) as f32,
            (len * (1.0 - 1e-4)) as f32,
        );
        !bvh.ray_traverse_miss(ray, |ray, id| {
            ftris[bvh.primitive_indices[id] as usize].intersect(ray)
        })
    };
    // obvhs with triangles reordered into leaf order (as its cornell_box example does).
    let ftris_ordered: Vec<FTri> = bvh
        .primitive_indices
        .iter()
        .map(|&i| ftris[i as usize])
        .collect();
    let direct_ordered = |q: &OcclusionQuery| {
        let d = q.q - q.p;
        let len = d.length();
        let ray = FRay::new(
            f3(q.p),
            f3(d / len),
            (1e-4 * len) as f32,
            (len * (1.0 - 1e-4)) as f32,
        );
        !bvh.ray_traverse_miss(ray, |ray, id| ftris_ordered[id].intersect(ray))
    };
    let disagree = qs
        .iter()
        .zip(&out)
        .filter(|(q, o)| direct(q) != **o)
        .count();
    eprintln!("{name}: obvhs-direct (f32, relative end epsilon 1e-4) disagrees on {disagree} rays");

    let mut g = c.benchmark_group(format!("occlusion_{name}"));
    g.throughput(Throughput::Elements(qs.len() as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(4));
    g.warm_up_time(Duration::from_secs(1));
    let mut out2 = vec![false; qs.len()];
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        g.bench_with_input(BenchmarkId::new("wrapper", threads), &threads, |b, _| {
            b.iter(|| pool.install(|| acc.occluded_queries(&qs, &mut out).expect("lengths match")))
        });
        g.bench_with_input(
            BenchmarkId::new("wrapper_input_order", threads),
            &threads,
            |b, _| {
                b.iter(|| {
                    pool.install(|| {
                        out2.par_iter_mut()
                            .with_min_len(256)
                            .zip(qs.par_iter())
                            .for_each(|(o, q)| *o = acc.occluded(q.p, q.q, q.ignore))
                    })
                })
            },
        );
        g.bench_with_input(
            BenchmarkId::new("obvhs_direct", threads),
            &threads,
            |b, _| {
                b.iter(|| {
                    pool.install(|| {
                        out2.par_iter_mut()
                            .with_min_len(256)
                            .zip(qs.par_iter())
                            .for_each(|(o, q)| *o = direct(q))
                    })
                })
            },
        );
        g.bench_with_input(
            BenchmarkId::new("obvhs_leaf_ordered", threads),
            &threads,
            |b, _| {
                b.iter(|| {
                    pool.install(|| {
                        out2.par_iter_mut()
                            .with_min_len(256)
                            .zip(qs.par_iter())
                            .for_each(|(o, q)| *o = direct_ordered(q))
                    })
                })
            },
        );
    }
    g.finish();
}

/// The room of `room_100k` with exact primitives: 6 wall parallelograms, 63 spheres
/// and 20 tori as `wavelux-param` trimmed patches (no trims); shadow rays between
/// points sampled on random primitives, `ignore` = their primitives.
fn bench_exact(c: &mut Criterion, n_rays: usize) {
    let mut r = Pcg64::seed_from_u64(3);
    let size = DVec3::new(10.0, 8.0, 3.0);
    let mut prims: Vec<Primitive> = Vec::new();
    for w in room(size, 1).chunks(2) {
        let [a, b, _] = w[0];
        let d = w[1][2];
        let p = wavelux_geometry::Parallelogram::new(a, b - a, d - a).expect("wall");
        prims.push(p.into());
    }
    for k in 0..83 {
        let ctr = DVec3::new(
            r.random_range(0.8..9.2),
            r.random_range(0.8..7.2),
            r.random_range(0.5..2.5),
        );
        let axis = DVec3::new(r.random_range(-1.0..1.0), r.random_range(-1.0..1.0), 1.0);
        let f = wparam::Frame::from_axis(ctr, axis).expect("frame");
        let s: Arc<dyn wparam::Parametrization> = if k < 63 {
            Arc::new(wparam::Sphere::full(f, r.random_range(0.1..0.45)).expect("sphere"))
        } else {
            let big = r.random_range(0.2..0.4);
            Arc::new(
                wparam::Torus::new(
                    f,
                    big,
                    0.3 * big,
                    (-std::f64::consts::PI, std::f64::consts::PI),
                    (-std::f64::consts::PI, std::f64::consts::PI),
                )
                .expect("torus"),
            )
        };
        prims.push(TrimmedPatch::new(s, None).expect("patch").into());
    }
    let acc = Accel::build(prims).expect("valid scene");
    let n = acc.len();
    let qs: Vec<OcclusionQuery> = (0..n_rays)
        .map(|_| {
            let i = r.random_range(0..n);
            let j = r.random_range(0..n);
            let uv = |r: &mut Pcg64| {
                glam::DVec2::new(r.random_range(0.0..1.0), r.random_range(0.0..1.0))
            };
            let p = acc.primitives()[i].eval(uv(&mut r));
            let q = acc.primitives()[j].eval(uv(&mut r));
            OcclusionQuery {
                p,
                q,
                ignore: [Some(i as u32), Some(j as u32)],
            }
        })
        .collect();
    let mut out = vec![false; qs.len()];
    let mut g = c.benchmark_group("occlusion_room_exact");
    g.throughput(Throughput::Elements(qs.len() as u64));
    g.sample_size(10);
    g.measurement_time(Duration::from_secs(4));
    g.warm_up_time(Duration::from_secs(1));
    for threads in [1usize, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("thread pool");
        g.bench_with_input(BenchmarkId::new("wrapper", threads), &threads, |b, _| {
            b.iter(|| pool.install(|| acc.occluded_queries(&qs, &mut out).expect("lengths match")))
        });
    }
    g.finish();
    eprintln!(
        "room_exact: {n} primitives, {} of {} rays occluded",
        out.iter().filter(|&&b| b).count(),
        qs.len()
    );
}

fn occlusion(c: &mut Criterion) {
    bench_exact(c, 20_000);
    let mut r = Pcg64::seed_from_u64(1);
    let room = scene_room(&mut r);
    bench_scene(c, "room_100k", room, 20_000);
    let big = scene_big(&mut r);
    bench_scene(c, "scene_1m", big, 20_000);
}

criterion_group!(benches, occlusion);
criterion_main!(benches);
