//! GPU occlusion against `Accel::occluded`: final answers equal the CPU's for every
//! query; the device's own sure answers (blocked/clear) agree with the CPU; few random
//! pairs are unsure. Scenes: built-ins, random triangle soups at scales 1e-6..1e6, an
//! exact-primitive room; rays through edges and vertices, grazing, with `ignore`,
//! along ±axes, coincident, from outside the scene box.

mod common;

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::sync::Arc;
use wavelux_geometry::backend::{Occluder, OcclusionBackend};
use wavelux_geometry::*;
use wavelux_gpu::occlusion::RawAnswer;
use wavelux_gpu::{Gpu, GpuOcclusion};

fn rv(r: &mut Pcg64, lo: f64, hi: f64) -> DVec3 {
    DVec3::new(
        r.random_range(lo..hi),
        r.random_range(lo..hi),
        r.random_range(lo..hi),
    )
}

/// Runs `qs` through the device; returns the unsure fraction.
fn check(gpu: &Arc<Gpu>, acc: &Accel, qs: &[OcclusionQuery], what: &str) -> f64 {
    let be = GpuOcclusion::new(gpu.clone());
    let occ = be.prepare(acc).unwrap();
    let raw = occ.raw(qs).unwrap();
    let mut out = vec![false; qs.len()];
    let stats = occ.occluded_queries(qs, &mut out).unwrap();
    let (mut unsure, mut blocked) = (0usize, 0usize);
    for (i, q) in qs.iter().enumerate() {
        let cpu = acc.occluded(q.p, q.q, q.ignore);
        assert_eq!(
            out[i], cpu,
            "{what}: query {i} {q:?}: gpu {} cpu {cpu}",
            out[i]
        );
        match raw[i] {
            RawAnswer::Blocked => assert!(cpu, "{what}: query {i} {q:?}: raw blocked, cpu clear"),
            RawAnswer::Clear => assert!(!cpu, "{what}: query {i} {q:?}: raw clear, cpu blocked"),
            RawAnswer::Unsure => unsure += 1,
        }
        blocked += usize::from(cpu);
    }
    assert_eq!(stats.queries, qs.len());
    assert_eq!(stats.deferred_rays, unsure);
    assert_eq!(stats.device_rays + stats.deferred_rays, qs.len());
    let frac = unsure as f64 / qs.len().max(1) as f64;
    eprintln!(
        "{what}: {} queries, {blocked} blocked, {unsure} unsure ({:.3} %)",
        qs.len(),
        100.0 * frac
    );
    frac
}

fn soup(seed: u64, n: usize, scale: f64) -> Vec<Primitive> {
    let mut r = Pcg64::seed_from_u64(seed);
    (0..n)
        .filter_map(|_| {
            let c = rv(&mut r, -5.0, 5.0);
            Triangle::new(
                (c + rv(&mut r, -0.6, 0.6)) * scale,
                (c + rv(&mut r, -0.6, 0.6)) * scale,
                (c + rv(&mut r, -0.6, 0.6)) * scale,
            )
            .ok()
            .map(Primitive::from)
        })
        .collect()
}

#[test]
fn random_triangle_soups_at_every_scale() {
    for gpu in common::gpus("occlusion_soups") {
        for (seed, scale) in [(1u64, 1e-6), (2, 1.0), (3, 1e6)] {
            let acc = Accel::build(soup(seed, 2000, scale)).unwrap();
            let mut r = Pcg64::seed_from_u64(seed + 10);
            let n = acc.len() as u32;
            let qs: Vec<OcclusionQuery> = (0..4000)
                .map(|i| OcclusionQuery {
                    p: rv(&mut r, -5.0, 5.0) * scale,
                    q: rv(&mut r, -5.0, 5.0) * scale,
                    ignore: if i % 2 == 0 {
                        [Some(r.random_range(0..n)), Some(r.random_range(0..n))]
                    } else {
                        [None, None]
                    },
                })
                .collect();
            let frac = check(&gpu, &acc, &qs, &format!("soup scale {scale:e}"));
            assert!(frac <= 0.01, "unsure fraction {frac}");
        }
    }
}

/// Points on primitive `i` (interior samples) with the primitive ignored, as the
/// solver's shadow rays are.
fn surface_pairs(acc: &Accel, n: usize, seed: u64) -> Vec<OcclusionQuery> {
    let mut r = Pcg64::seed_from_u64(seed);
    let prims = acc.primitives();
    (0..n)
        .map(|_| {
            let i = r.random_range(0..prims.len());
            let j = r.random_range(0..prims.len());
            let uv =
                |r: &mut Pcg64| DVec2::new(r.random_range(0.05..0.95), r.random_range(0.05..0.95));
            let (ui, uj) = (uv(&mut r), uv(&mut r));
            OcclusionQuery {
                p: prims[i].eval(ui),
                q: prims[j].eval(uj),
                ignore: [Some(i as u32), Some(j as u32)],
            }
        })
        .collect()
}

#[test]
fn built_in_scenes_answer_like_the_cpu() {
    let gpus = common::gpus("occlusion_builtins");
    if gpus.is_empty() {
        return;
    }
    for name in [
        "cornell-box",
        "ziegler-occluded",
        "office",
        "quadric-teapot",
    ] {
        let scene = wavelux_scene::builtin::builtin(name).unwrap();
        let prims: Vec<Primitive> = scene
            .primitives("<built-in>")
            .unwrap()
            .into_iter()
            .map(|(_, p)| p)
            .collect();
        let curved = prims.iter().filter(|p| !p.is_planar()).count();
        let acc = Accel::build(prims).unwrap();
        let qs = surface_pairs(&acc, 3000, 7);
        // Random pairs in the scene box.
        let b = acc.bounds();
        let mut r = Pcg64::seed_from_u64(8);
        let boxed: Vec<OcclusionQuery> = (0..3000)
            .map(|_| {
                let mut pt = || b.min + (b.max - b.min) * rv(&mut r, 0.0, 1.0);
                OcclusionQuery {
                    p: pt(),
                    q: pt(),
                    ignore: [None, None],
                }
            })
            .collect();
        for gpu in &gpus {
            // Surface-to-surface pairs (the solver's shadow rays): end points on a
            // surface coplanar with a neighbour (the Cornell light in its ceiling hole)
            // cross that neighbour's plane within f32 rounding of the end point, far
            // inside the CPU's 1e-9·D end-point interval, so they are unsure by design.
            check(gpu, &acc, &qs, &format!("{name} surface pairs"));
            let frac = check(gpu, &acc, &boxed, &format!("{name} random pairs"));
            if curved == 0 {
                assert!(frac <= 0.01, "{name}: unsure fraction {frac}");
            }
        }
    }
}

#[test]
fn special_rays_in_an_exact_primitive_room() {
    // A unit room of parallelograms, a grid of triangles sharing edges and vertices on
    // the floor, a complex polygon and a sphere.
    let mut prims: Vec<Primitive> = Vec::new();
    let o = DVec3::ZERO;
    for (org, e1, e2) in [
        (o, DVec3::Y, DVec3::Z),
        (DVec3::X, DVec3::Z, DVec3::Y),
        (o, DVec3::Z, DVec3::X),
        (DVec3::Y, DVec3::X, DVec3::Z),
        (DVec3::Z, DVec3::Y, DVec3::X),
    ] {
        prims.push(Parallelogram::new(org, e1, e2).unwrap().into());
    }
    let n = 8;
    let h = 1.0 / n as f64;
    for i in 0..n {
        for j in 0..n {
            let p = |a: usize, b: usize| DVec3::new(a as f64 * h, b as f64 * h, 0.0);
            prims.push(
                Triangle::new(p(i, j), p(i + 1, j), p(i + 1, j + 1))
                    .unwrap()
                    .into(),
            );
            prims.push(
                Triangle::new(p(i, j), p(i + 1, j + 1), p(i, j + 1))
                    .unwrap()
                    .into(),
            );
        }
    }
    let lp = [
        DVec3::new(0.3, 0.3, 0.5),
        DVec3::new(0.7, 0.3, 0.5),
        DVec3::new(0.7, 0.7, 0.5),
        DVec3::new(0.5, 0.4, 0.5),
        DVec3::new(0.3, 0.7, 0.5),
    ];
    prims.push(ComplexPolygon::from_world_loops(&lp, &[]).unwrap().into());
    let quad = [
        DVec3::new(0.6, 0.2, 0.3),
        DVec3::new(0.9, 0.2, 0.3),
        DVec3::new(0.95, 0.6, 0.3),
        DVec3::new(0.55, 0.5, 0.3),
    ];
    prims.push(ComplexPolygon::from_world_loops(&quad, &[]).unwrap().into());
    let f = wavelux_param::Frame::from_axis(DVec3::new(0.2, 0.8, 0.3), DVec3::Z).unwrap();
    let sphere: Arc<dyn wavelux_param::Parametrization> =
        Arc::new(wavelux_param::Sphere::full(f, 0.1).unwrap());
    prims.push(TrimmedPatch::new(sphere, None).unwrap().into());
    let acc = Accel::build(prims).unwrap();
    let mut qs = Vec::new();
    let up = |x: f64, y: f64| DVec3::new(x, y, 0.9);
    let below = |x: f64, y: f64| DVec3::new(x, y, -0.1);
    // Through shared vertices and edges of the floor grid (from above to below).
    for i in 1..n {
        for j in 1..n {
            let (x, y) = (i as f64 * h, j as f64 * h);
            qs.push(OcclusionQuery {
                p: up(x, y),
                q: below(x, y),
                ignore: [None, None],
            });
            qs.push(OcclusionQuery {
                p: up(x + 0.5 * h, y),
                q: below(x + 0.5 * h, y),
                ignore: [None, None],
            });
        }
    }
    // Grazing: inside the floor plane and just above it; along ±axes; coincident end
    // points; from outside the scene box; with the end points' surfaces ignored.
    let mut r = Pcg64::seed_from_u64(9);
    for _ in 0..200 {
        let (a, b) = (r.random_range(0.0..1.0), r.random_range(0.0..1.0));
        qs.push(OcclusionQuery {
            p: DVec3::new(a, b, 0.0),
            q: DVec3::new(b, a, 0.0),
            ignore: [None, None],
        });
        qs.push(OcclusionQuery {
            p: DVec3::new(a, b, 1e-9),
            q: DVec3::new(b, a, 1e-9),
            ignore: [None, None],
        });
        let c = rv(&mut r, 0.05, 0.95);
        for axis in [DVec3::X, DVec3::Y, DVec3::Z] {
            qs.push(OcclusionQuery {
                p: c,
                q: c + axis * 2.0,
                ignore: [None, None],
            });
            qs.push(OcclusionQuery {
                p: c,
                q: c - axis * 2.0,
                ignore: [None, None],
            });
            qs.push(OcclusionQuery {
                p: c,
                q: c + axis * 0.3,
                ignore: [None, None],
            });
        }
        qs.push(OcclusionQuery {
            p: c,
            q: c,
            ignore: [None, None],
        });
        qs.push(OcclusionQuery {
            p: rv(&mut r, -3.0, 4.0),
            q: rv(&mut r, -3.0, 4.0),
            ignore: [None, None],
        });
        // From the floor (a triangle) to the back wall (parallelogram 0), ignored.
        let fi = r.random_range(0..(2 * n * n)) as u32 + 5;
        let fp = acc.primitives()[fi as usize].eval(DVec2::new(0.3, 0.3));
        qs.push(OcclusionQuery {
            p: fp,
            q: DVec3::new(0.0, r.random_range(0.0..1.0), r.random_range(0.0..1.0)),
            ignore: [Some(fi), Some(0)],
        });
    }
    for gpu in common::gpus("occlusion_room") {
        check(&gpu, &acc, &qs, "exact room");
        // Batches cut into many small dispatches give the same answers.
        let small = GpuOcclusion::new(gpu.clone()).with_binding_limit(16384);
        let occ = small.occluder(&acc).unwrap();
        let mut out = vec![false; qs.len()];
        occ.occluded_queries(&qs, &mut out).unwrap();
        for (i, q) in qs.iter().enumerate() {
            assert_eq!(
                out[i],
                acc.occluded(q.p, q.q, q.ignore),
                "chunked query {i}"
            );
        }
        // Mismatched lengths are a typed error; an empty scene is never occluded.
        assert!(occ.occluded_queries(&qs, &mut out[1..]).is_err());
        let empty = Accel::build(Vec::new()).unwrap();
        let e = GpuOcclusion::new(gpu.clone()).occluder(&empty).unwrap();
        let mut o = vec![true; 3];
        e.occluded_queries(&qs[..3], &mut o).unwrap();
        assert_eq!(o, vec![false; 3]);
    }
}
