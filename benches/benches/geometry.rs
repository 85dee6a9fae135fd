//! Geometry benches: occlusion rays per second through `wavelux-geometry`'s `Accel`
//! (f64 exact tests, `ignore` ids, scale-aware epsilons) against obvhs called directly
//! (f32 Möller–Trumbore in the traversal callback) on the same BVH preset and the same
//! rays, with 1 and 2 rayon threads, in a ~100k-triangle room and a ~1M-triangle scene.
//! The ratio `wrapper / obvhs` of the times is the wrapper's overhead.
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
use wavelux_geometry::{Accel, OcclusionQuery, Primitive, Triangle, TrimmedPatch};

/// Icosphere triangles (outward), `level` subdivisions of the icosahedron.
fn icosphere(center: DVec3, r: f64, level: u32) -> Vec<[DVec3; 3]> {
    let t = (1.0 + 5f64.sqrt()) / 2.0;
    let v0 = [
        (-1., t, 0.),
        (1., t, 0.),
        (-1., -t, 0.),
        (1., -t, 0.),
        (0., -1., t),
        (0., 1., t),
        (0., -1., -t),
        (0., 1., -t),
        (t, 0., -1.),
        (t, 0., 1.),
        (-t, 0., -1.),
        (-t, 0., 1.),
    ];
    let f0: [[usize; 3]; 20] = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    let mut tris: Vec<[DVec3; 3]> = f0
        .iter()
        .map(|f| f.map(|i| DVec3::new(v0[i].0, v0[i].1, v0[i].2).normalize()))
        .collect();
    for _ in 0..level {
        let mut next = Vec::with_capacity(tris.len() * 4);
        for [a, b, c] in tris {
            let (ab, bc, ca) = (
                (a + b).normalize(),
                (b + c).normalize(),
                (c + a).normalize(),
            );
            next.extend([[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    tris.into_iter()
        .map(|t| t.map(|p| center + r * p))
        .collect()
}

/// Axis-aligned box room `size`, each wall an `n × n` grid of quads (2 triangles each).
fn room(size: DVec3, n: usize) -> Vec<[DVec3; 3]> {
    let mut out = Vec::new();
    let walls: [(DVec3, DVec3, DVec3); 6] = [
        (
            DVec3::ZERO,
            DVec3::new(size.x, 0.0, 0.0),
            DVec3::new(0.0, size.y, 0.0),
        ),
        (
            DVec3::new(0.0, 0.0, size.z),
            DVec3::new(0.0, size.y, 0.0),
            DVec3::new(size.x, 0.0, 0.0),
        ),
        (
            DVec3::ZERO,
            DVec3::new(0.0, 0.0, size.z),
            DVec3::new(size.x, 0.0, 0.0),
        ),
        (
            DVec3::new(0.0, size.y, 0.0),
            DVec3::new(size.x, 0.0, 0.0),
            DVec3::new(0.0, 0.0, size.z),
        ),
        (
            DVec3::ZERO,
            DVec3::new(0.0, size.y, 0.0),
            DVec3::new(0.0, 0.0, size.z),
        ),
        (
            DVec3::new(size.x, 0.0, 0.0),
            DVec3::new(0.0, 0.0, size.z),
            DVec3::new(0.0, size.y, 0.0),
        ),
    ];
    for (o, e1, e2) in walls {
        for i in 0..n {
            for j in 0..n {
                let p = |a: usize, b: usize| {
                    o + (a as f64 / n as f64) * e1 + (b as f64 / n as f64) * e2
                };
                out.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
                out.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
            }
        }
    }
    out
}

/// ~100k triangles: a 10×8×3 room (19 200 wall triangles) with 63 level-3 icospheres.
fn scene_room(r: &mut Pcg64) -> Vec<[DVec3; 3]> {
    let size = DVec3::new(10.0, 8.0, 3.0);
    let mut tris = room(size, 40);
    for _ in 0..63 {
        let c = DVec3::new(
            r.random_range(0.8..9.2),
            r.random_range(0.8..7.2),
            r.random_range(0.5..2.5),
        );
        tris.extend(icosphere(c, r.random_range(0.1..0.45), 3));
    }
    tris
}

/// ~1M triangles: a 60×60×20 hall (120k wall triangles) with 690 level-3 icospheres.
fn scene_big(r: &mut Pcg64) -> Vec<[DVec3; 3]> {
    let size = DVec3::new(60.0, 60.0, 20.0);
    let mut tris = room(size, 100);
    for _ in 0..690 {
        let c = DVec3::new(
            r.random_range(2.0..58.0),
            r.random_range(2.0..58.0),
            r.random_range(1.0..19.0),
        );
        tris.extend(icosphere(c, r.random_range(0.2..1.5), 3));
    }
    tris
}

/// Shadow-ray end points sampled uniformly on two random triangles each.
fn queries(tris: &[[DVec3; 3]], n: usize, r: &mut Pcg64) -> Vec<OcclusionQuery> {
    let sample = |r: &mut Pcg64| {
        let i = r.random_range(0..tris.len());
        let (mut a, mut b) = (r.random_range(0.0..1.0f64), r.random_range(0.0..1.0f64));
        if a + b > 1.0 {
            (a, b) = (1.0 - a, 1.0 - b);
        }
        let [p, q, s] = tris[i];
        (p + a * (q - p) + b * (s - p), i as u32)
    };
    (0..n)
        .map(|_| {
            let (p, i) = sample(r);
            let (q, j) = sample(r);
            OcclusionQuery {
                p,
                q,
                ignore: [Some(i), Some(j)],
            }
        })
        .collect()
}

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
