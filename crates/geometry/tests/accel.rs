//! The obvhs accelerator vs brute force; no acne, no leaks through shared edges/corners.

use glam::{DVec2, DVec3};
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;
use std::sync::Arc;
use wavelux_geometry::*;
use wavelux_param as param;

fn rv(r: &mut Pcg64, lo: f64, hi: f64) -> DVec3 {
    DVec3::new(
        r.random_range(lo..hi),
        r.random_range(lo..hi),
        r.random_range(lo..hi),
    )
}

fn random_scene(seed: u64, n_tri: usize) -> Vec<Primitive> {
    let mut r = Pcg64::seed_from_u64(seed);
    let mut prims: Vec<Primitive> = Vec::new();
    for _ in 0..n_tri {
        let c = rv(&mut r, -5.0, 5.0);
        let s = r.random_range(0.05..0.8);
        if let Ok(t) = Triangle::new(
            c + rv(&mut r, -s, s),
            c + rv(&mut r, -s, s),
            c + rv(&mut r, -s, s),
        ) {
            prims.push(t.into());
        }
    }
    for _ in 0..20 {
        let c = rv(&mut r, -5.0, 5.0);
        if let Ok(p) = Parallelogram::new(c, rv(&mut r, -1.0, 1.0), rv(&mut r, -1.0, 1.0)) {
            prims.push(p.into());
        }
    }
    let pts = [
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.5, 0.3, 0.0),
        DVec3::Y,
    ];
    for _ in 0..5 {
        let c = rv(&mut r, -5.0, 5.0);
        let lp: Vec<DVec3> = pts.iter().map(|p| c + *p).collect();
        prims.push(ComplexPolygon::from_world_loops(&lp, &[]).unwrap().into());
    }
    for k in 0..6 {
        let c = rv(&mut r, -4.0, 4.0);
        let f = param::Frame::from_axis(c, rv(&mut r, -1.0, 1.0) + DVec3::Z * 0.1).unwrap();
        let s: Arc<dyn param::Parametrization> = match k % 3 {
            0 => Arc::new(param::Sphere::full(f, 0.6).unwrap()),
            1 => Arc::new(param::Torus::new(f, 0.8, 0.25, (-PI, PI), (-PI, PI)).unwrap()),
            _ => Arc::new(param::Cylinder::new(f, 0.4, (0.0, 4.0), (0.0, 1.0)).unwrap()),
        };
        let trim = TrimRegion::new(vec![
            TrimLoop::rect(DVec2::splat(0.0), DVec2::splat(1.0)).unwrap(),
            TrimLoop::circle(DVec2::splat(0.5), 0.2).unwrap().reversed(),
        ])
        .unwrap();
        prims.push(TrimmedPatch::new(s, Some(trim)).unwrap().into());
    }
    let mut p = [[DVec3::ZERO; 4]; 4];
    for i in 0..4 {
        for j in 0..4 {
            p[i][j] = DVec3::new(i as f64 * 0.5, j as f64 * 0.5, ((i + j) % 3) as f64 * 0.3)
                + DVec3::new(1.0, -2.0, 0.5);
        }
    }
    prims.push(BezierPatch::new(p).unwrap().into());
    prims
}

#[test]
fn occlusion_and_closest_hit_equal_brute_force() {
    for seed in 0..3 {
        let scene = random_scene(seed, 400);
        let acc = Accel::build(scene).unwrap();
        let mut r = Pcg64::seed_from_u64(100 + seed);
        let mut pairs = Vec::new();
        for _ in 0..1500 {
            pairs.push((rv(&mut r, -6.0, 6.0), rv(&mut r, -6.0, 6.0)));
        }
        let mut out = vec![false; pairs.len()];
        acc.occluded_batch(&pairs, &mut out).unwrap();
        let mut n_occ = 0;
        for (k, (p, q)) in pairs.iter().enumerate() {
            let brute = acc.occluded_brute(*p, *q, [None, None]);
            assert_eq!(out[k], brute, "pair {k}");
            assert_eq!(acc.occluded(*p, *q, [None, None]), brute);
            n_occ += usize::from(brute);
            let ray = Ray::new(*p, *q - *p).unwrap();
            let a = acc.closest_hit(&ray, 0.0, f64::INFINITY);
            let b = acc.closest_hit_brute(&ray, 0.0, f64::INFINITY);
            assert_eq!(
                a.map(|h| h.prim),
                b.map(|h| h.prim),
                "closest prim, pair {k}"
            );
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a.t - b.t).abs() <= 1e-12 * (1.0 + a.t));
                assert!((acc.primitives()[a.prim as usize].eval(a.uv) - a.point).length() < 1e-8);
            }
        }
        assert!(
            n_occ > 100 && n_occ < 1400,
            "scene should be partly occluding: {n_occ}"
        );
    }
}

#[test]
fn occlusion_with_ignore_ids_equals_brute_force() {
    // End points on random primitives (the radiosity use case), their ids ignored.
    let acc = Accel::build(random_scene(5, 300)).unwrap();
    let n = acc.len();
    let mut r = Pcg64::seed_from_u64(55);
    let mut queries = Vec::new();
    for _ in 0..1500 {
        let i = r.random_range(0..n);
        let j = r.random_range(0..n);
        let uv = |r: &mut Pcg64| DVec2::new(r.random_range(0.0..1.0), r.random_range(0.0..1.0));
        let p = acc.primitives()[i].eval(uv(&mut r));
        let q = acc.primitives()[j].eval(uv(&mut r));
        queries.push(OcclusionQuery {
            p,
            q,
            ignore: [Some(i as u32), Some(j as u32)],
        });
    }
    let mut out = vec![false; queries.len()];
    acc.occluded_queries(&queries, &mut out).unwrap();
    let mut n_occ = 0;
    for (k, qu) in queries.iter().enumerate() {
        assert_eq!(
            out[k],
            acc.occluded_brute(qu.p, qu.q, qu.ignore),
            "query {k}"
        );
        n_occ += usize::from(out[k]);
    }
    assert!(n_occ > 50 && n_occ < 1450, "{n_occ}");
}

/// Batches of `COHERENT_MIN` or more are answered in a coherent order (sorted by
/// direction octant and origin); every answer must still land at its own index and
/// equal the one-by-one answer (and brute force on a sample), NaN end points included.
#[test]
fn coherent_batches_answer_each_query_at_its_index() {
    let acc = Accel::build(random_scene(7, 300)).unwrap();
    let n = acc.len();
    let m = wavelux_geometry::accel::COHERENT_MIN + 904;
    let mut r = Pcg64::seed_from_u64(77);
    let mut pairs: Vec<(DVec3, DVec3)> = (0..m)
        .map(|_| (rv(&mut r, -6.0, 6.0), rv(&mut r, -6.0, 6.0)))
        .collect();
    pairs[17] = (DVec3::splat(f64::NAN), DVec3::ONE);
    let mut out = vec![false; m];
    acc.occluded_batch(&pairs, &mut out).unwrap();
    assert!(!out[17]);
    let queries: Vec<OcclusionQuery> = pairs
        .iter()
        .map(|&(p, q)| OcclusionQuery {
            p,
            q,
            ignore: [Some(r.random_range(0..n) as u32), None],
        })
        .collect();
    let mut outq = vec![false; m];
    acc.occluded_queries(&queries, &mut outq).unwrap();
    let rays: Vec<Ray> = pairs[..17]
        .iter()
        .chain(&pairs[18..])
        .map(|&(p, q)| Ray::new(p, q - p).unwrap())
        .collect();
    let mut hits = vec![None; rays.len()];
    acc.closest_hit_batch(&rays, 0.0, f64::INFINITY, &mut hits)
        .unwrap();
    let mut n_occ = 0;
    for (k, &(p, q)) in pairs.iter().enumerate() {
        assert_eq!(out[k], acc.occluded(p, q, [None, None]), "pair {k}");
        let qu = &queries[k];
        assert_eq!(outq[k], acc.occluded(qu.p, qu.q, qu.ignore), "query {k}");
        if k % 16 == 0 {
            assert_eq!(out[k], acc.occluded_brute(p, q, [None, None]), "pair {k}");
        }
        n_occ += usize::from(out[k]);
    }
    for (k, ray) in rays.iter().enumerate() {
        let one = acc.closest_hit(ray, 0.0, f64::INFINITY);
        assert_eq!(
            hits[k].map(|h| (h.prim, h.t)),
            one.map(|h| (h.prim, h.t)),
            "ray {k}"
        );
    }
    assert!(n_occ > m / 10 && n_occ < m - m / 10, "{n_occ} of {m}");
}

#[test]
fn batch_length_mismatch_is_an_error() {
    let acc = Accel::build(random_scene(9, 10)).unwrap();
    let mut out = vec![false; 1];
    assert!(acc.occluded_batch(&[], &mut out).is_err());
}

/// Closed box [0,1]³ from 12 triangles (or 6 parallelograms), inward-facing.
fn box_prims(tris: bool, s: f64, off: DVec3) -> Vec<Primitive> {
    let v = |x: f64, y: f64, z: f64| off + s * DVec3::new(x, y, z);
    let quads = [
        [v(0., 0., 0.), v(1., 0., 0.), v(1., 1., 0.), v(0., 1., 0.)],
        [v(0., 0., 1.), v(0., 1., 1.), v(1., 1., 1.), v(1., 0., 1.)],
        [v(0., 0., 0.), v(0., 0., 1.), v(1., 0., 1.), v(1., 0., 0.)],
        [v(0., 1., 0.), v(1., 1., 0.), v(1., 1., 1.), v(0., 1., 1.)],
        [v(0., 0., 0.), v(0., 1., 0.), v(0., 1., 1.), v(0., 0., 1.)],
        [v(1., 0., 0.), v(1., 0., 1.), v(1., 1., 1.), v(1., 1., 0.)],
    ];
    let mut out = Vec::new();
    for q in quads {
        if tris {
            out.push(Triangle::new(q[0], q[1], q[2]).unwrap().into());
            out.push(Triangle::new(q[0], q[2], q[3]).unwrap().into());
        } else {
            out.push(
                Parallelogram::new(q[0], q[1] - q[0], q[3] - q[0])
                    .unwrap()
                    .into(),
            );
        }
    }
    out
}

#[test]
fn no_leaks_through_shared_edges_and_corners() {
    for tris in [true, false] {
        for &(s, off) in &[
            (1.0, DVec3::ZERO),
            (1e-3, DVec3::splat(5.0)),
            (1e3, DVec3::splat(-2e3)),
        ] {
            let acc = Accel::build(box_prims(tris, s, off)).unwrap();
            let c = off + DVec3::splat(0.5 * s);
            // Aim exactly at every corner, edge midpoint and face diagonal point, from inside
            // to far outside, and along many random directions through edges.
            let mut targets = Vec::new();
            for i in 0..3 {
                for j in 0..3 {
                    for k in 0..3 {
                        targets.push(off + 0.5 * s * DVec3::new(i as f64, j as f64, k as f64));
                    }
                }
            }
            let mut r = Pcg64::seed_from_u64(3);
            for _ in 0..300 {
                // Random points on random cube edges.
                let t = r.random_range(0.0..1.0);
                let e = r.random_range(0..12usize);
                let (a, b) = (e % 4, e / 4);
                let mut p = [0.0f64; 3];
                p[b] = t;
                p[(b + 1) % 3] = (a & 1) as f64;
                p[(b + 2) % 3] = (a >> 1) as f64;
                targets.push(off + s * DVec3::from_array(p));
            }
            for tgt in targets {
                if (tgt - c).length() < 1e-9 * s {
                    continue;
                }
                let far = c + 10.0 * (tgt - c);
                assert!(
                    acc.occluded(c, far, [None, None]),
                    "leak towards {tgt:?} (tris={tris}, s={s})"
                );
                let ray = Ray::new(c, tgt - c).unwrap();
                assert!(
                    acc.closest_hit(&ray, 0.0, f64::INFINITY).is_some(),
                    "closest-hit leak (tris={tris})"
                );
            }
        }
    }
}

#[test]
fn no_self_shadowing_between_surface_points() {
    // Inside a closed box every pair of points on two faces sees each other, with and
    // without naming the end points' primitives; also inside a sphere.
    for &(scale, off) in &[
        (2.0, DVec3::new(0.3, -1.0, 7.0)),
        (1e-3, DVec3::splat(3.0)),
        (1e3, DVec3::splat(-5e3)),
    ] {
        for tris in [false, true] {
            let acc = Accel::build(box_prims(tris, scale, off)).unwrap();
            let n = acc.len();
            let mut r = Pcg64::seed_from_u64(4);
            for _ in 0..1000 {
                let i = r.random_range(0..n);
                let j = r.random_range(0..n);
                let uvi = DVec2::new(r.random_range(0.0..1.0), r.random_range(0.0..1.0));
                let uvj = DVec2::new(r.random_range(0.0..1.0), r.random_range(0.0..1.0));
                let p = acc.primitives()[i].eval(uvi);
                let q = acc.primitives()[j].eval(uvj);
                assert!(
                    !acc.occluded(p, q, [Some(i as u32), Some(j as u32)]),
                    "scale {scale}"
                );
                assert!(
                    !acc.occluded(p, q, [None, None]),
                    "acne between {i} and {j} at scale {scale} (tris={tris})"
                );
            }
        }
    }
    let mut r = Pcg64::seed_from_u64(5);
    let f = param::Frame::from_axis(DVec3::new(1.0, 2.0, 3.0), DVec3::new(0.3, 0.1, 1.0)).unwrap();
    let sph: Arc<dyn param::Parametrization> = Arc::new(param::Sphere::full(f, 1.7).unwrap());
    let acc = Accel::build(vec![TrimmedPatch::new(sph.clone(), None).unwrap().into()]).unwrap();
    for _ in 0..2000 {
        let p = sph.position(DVec2::new(
            r.random_range(0.0..1.0),
            r.random_range(0.0..1.0),
        ));
        let q = sph.position(DVec2::new(
            r.random_range(0.0..1.0),
            r.random_range(0.0..1.0),
        ));
        assert!(!acc.occluded(p, q, [Some(0), Some(0)]));
        assert!(!acc.occluded(p, q, [None, None]));
    }
}

#[test]
fn curved_primitives_still_shadow_themselves() {
    // Points at ±x on a torus's outer equator: the segment between them runs inside the
    // tube (x from 1.3 to 0.7), crosses the hole and the other side of the tube, so the
    // torus occludes it, also when it is named in `ignore`.
    let f = param::Frame::at(DVec3::ZERO).unwrap();
    let tor: Arc<dyn param::Parametrization> =
        Arc::new(param::Torus::new(f, 1.0, 0.3, (-PI, PI), (-PI, PI)).unwrap());
    let acc = Accel::build(vec![TrimmedPatch::new(tor, None).unwrap().into()]).unwrap();
    let p = DVec3::new(1.3, 0.0, 0.0);
    let q = DVec3::new(-1.3, 0.0, 0.0);
    assert!(acc.occluded(p, q, [Some(0), Some(0)]));
    assert!(acc.occluded(p, q, [None, None]));
    // Two nearby points on the outer equator see each other.
    let a = 0.2f64;
    let q2 = DVec3::new(1.3 * a.cos(), 1.3 * a.sin(), 0.0);
    assert!(!acc.occluded(p, q2, [Some(0), Some(0)]));
}

#[test]
fn exact_sphere_closure_with_trimmed_patches_and_visibility() {
    // Inside a sphere the kernel cos θx cos θy / (π r²) is the constant 1/(4πR²), so
    // F_ij = A_j / (4πR²) and Σ_j F_ij = 1 (self-exchange included). Two trimmed patches
    // of an equal-area sphere (a disk in (u, v) with an arc boundary, and the rest) are
    // integrated with slab-cell Gauss–Legendre rules, the visibility of every pair of
    // points queried through the accelerator.
    let radius = 1.3;
    let f = param::Frame::from_axis(DVec3::new(0.2, -0.4, 1.0), DVec3::new(0.3, 0.1, 1.0)).unwrap();
    let sph: Arc<dyn param::Parametrization> = Arc::new(param::Sphere::full(f, radius).unwrap());
    let disk = TrimRegion::new(vec![TrimLoop::circle(DVec2::splat(0.5), 0.3).unwrap()]).unwrap();
    let rest = TrimRegion::new(vec![
        TrimLoop::rect(DVec2::ZERO, DVec2::ONE).unwrap(),
        TrimLoop::circle(DVec2::splat(0.5), 0.3).unwrap().reversed(),
    ])
    .unwrap();
    let patches = [
        TrimmedPatch::new(sph.clone(), Some(disk)).unwrap(),
        TrimmedPatch::new(sph.clone(), Some(rest)).unwrap(),
    ];
    let acc = Accel::build(patches.iter().cloned().map(Primitive::from).collect()).unwrap();
    let total = 4.0 * PI * radius * radius;
    assert!((patches[0].area() + patches[1].area() - total).abs() <= 1e-12 * total);
    let jac = sph.area();
    let mut blocked = 0usize;
    for i in 0..2 {
        let ti = patches[i].trim.as_ref().unwrap();
        let mut row = 0.0;
        for j in 0..2 {
            let tj = patches[j].trim.as_ref().unwrap();
            let fij = ti.integrate(10, |ui| {
                let x = sph.position(ui);
                let nx = -sph.normal(ui);
                // A different order inside keeps the two point sets disjoint (i == j).
                tj.integrate(11, |uj| {
                    let y = sph.position(uj);
                    let ny = -sph.normal(uj);
                    let d = y - x;
                    let r2 = d.length_squared();
                    assert!(r2 > 0.0);
                    if acc.occluded(x, y, [Some(i as u32), Some(j as u32)]) {
                        blocked += 1;
                        return 0.0;
                    }
                    nx.dot(d) * ny.dot(-d) / (PI * r2 * r2) * jac * jac
                })
            }) / patches[i].area();
            assert!(
                (fij - patches[j].area() / total).abs() <= 1e-10,
                "F_{i}{j} = {fij}, expected {}, {blocked} blocked",
                patches[j].area() / total
            );
            row += fij;
        }
        assert!((row - 1.0).abs() <= 1e-10, "closure row {i}: {}", row - 1.0);
    }
    assert_eq!(blocked, 0, "points inside a sphere all see each other");
}

/// Random triangles and parallelograms in a box of size `scale` centred at
/// `scale · (3, −2, 1)` (an off-origin frame), plus query segments: long random ones and
/// short ones ending just past (or just short of) a random primitive, so that blockers
/// close to an end point are exercised.
fn scaled_scene_and_queries(seed: u64, scale: f64) -> (Vec<Primitive>, Vec<(DVec3, DVec3)>) {
    let mut r = Pcg64::seed_from_u64(seed);
    let off = DVec3::new(3.0, -2.0, 1.0) * scale;
    let mut prims: Vec<Primitive> = Vec::new();
    let mut centres = Vec::new();
    for k in 0..60 {
        let c = rv(&mut r, -1.0, 1.0);
        let s = r.random_range(0.02..0.3);
        let (a, b, d) = (rv(&mut r, -s, s), rv(&mut r, -s, s), rv(&mut r, -s, s));
        let prim: Option<Primitive> = if k % 4 == 0 {
            Parallelogram::new(off + c * scale, a * scale, b * scale)
                .ok()
                .map(Into::into)
        } else {
            Triangle::new(
                off + (c + a) * scale,
                off + (c + b) * scale,
                off + (c + d) * scale,
            )
            .ok()
            .map(Into::into)
        };
        if let Some(p) = prim {
            centres.push(match &p {
                Primitive::Triangle(t) => (t.v[0] + t.v[1] + t.v[2]) / 3.0,
                _ => off + (c + 0.5 * (a + b)) * scale,
            });
            prims.push(p);
        }
    }
    let mut pairs = Vec::new();
    for _ in 0..150 {
        pairs.push((
            off + rv(&mut r, -1.2, 1.2) * scale,
            off + rv(&mut r, -1.2, 1.2) * scale,
        ));
    }
    for _ in 0..150 {
        // A short segment through (or near) a primitive's centre: blocker at ~1e-5 to
        // 1e-2 of the scene size from the start point.
        let c = centres[r.random_range(0..centres.len())];
        let dir = rv(&mut r, -1.0, 1.0).normalize_or(DVec3::Z);
        let before = 10f64.powf(r.random_range(-5.0..-2.0)) * scale;
        let after = r.random_range(-0.5..2.0) * before;
        pairs.push((c - dir * before, c + dir * after));
    }
    (prims, pairs)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig::with_cases(12))]
    /// Visibility must not depend on the unit of length: the f32 BVH traversal runs in a
    /// normalised frame, so occlusion and closest hits equal brute force (f64) from
    /// micro- to mega-scale scenes.
    #[test]
    fn occlusion_equals_brute_force_at_every_scale(
        seed in 0u64..1_000_000,
        exp in proptest::sample::select(vec![-6i32, -4, 0, 4, 6]),
    ) {
        let scale = 10f64.powi(exp);
        let (prims, pairs) = scaled_scene_and_queries(seed, scale);
        let acc = Accel::build(prims).unwrap();
        let mut n_occ = 0;
        for (k, (p, q)) in pairs.iter().enumerate() {
            let brute = acc.occluded_brute(*p, *q, [None, None]);
            proptest::prop_assert_eq!(acc.occluded(*p, *q, [None, None]), brute, "pair {}", k);
            n_occ += usize::from(brute);
            let ray = Ray::new(*p, *q - *p).unwrap();
            let a = acc.closest_hit(&ray, 0.0, f64::INFINITY);
            let b = acc.closest_hit_brute(&ray, 0.0, f64::INFINITY);
            proptest::prop_assert_eq!(a.map(|h| h.prim), b.map(|h| h.prim), "closest, pair {}", k);
        }
        proptest::prop_assert!(n_occ > 20, "scene should occlude some segments: {}", n_occ);
    }
}

/// Axis-aligned rays whose other components are negative zero (e.g. `-DVec3::X`, as
/// a camera looking down an axis produces) hit exactly what brute force hits.
#[test]
fn negative_zero_directions_hit_like_brute_force() {
    let wall = |o: DVec3, u: DVec3, v: DVec3| {
        Primitive::Parallelogram(Parallelogram::new(o, u, v).unwrap())
    };
    let prims = vec![
        wall(DVec3::new(-2.0, -1.0, -1.0), DVec3::Y * 2.0, DVec3::Z * 2.0),
        wall(DVec3::new(2.0, -1.0, -1.0), DVec3::Z * 2.0, DVec3::Y * 2.0),
        wall(DVec3::new(-1.0, -2.0, -1.0), DVec3::Z * 2.0, DVec3::X * 2.0),
        wall(DVec3::new(-1.0, 2.0, -1.0), DVec3::X * 2.0, DVec3::Z * 2.0),
        wall(DVec3::new(-1.0, -1.0, -2.0), DVec3::X * 2.0, DVec3::Y * 2.0),
        wall(DVec3::new(-1.0, -1.0, 2.0), DVec3::Y * 2.0, DVec3::X * 2.0),
    ];
    let accel = Accel::build(prims).unwrap();
    for dir in [
        -DVec3::X,
        -DVec3::Y,
        -DVec3::Z,
        DVec3::X,
        DVec3::Y,
        DVec3::Z,
        DVec3::new(-0.0, -0.0, -1.0),
        DVec3::new(1.0, -0.0, 0.0),
    ] {
        for origin in [DVec3::ZERO, DVec3::new(0.3, -0.2, 0.1)] {
            let ray = Ray::new(origin, dir).unwrap();
            let fast = accel.closest_hit(&ray, 0.0, f64::INFINITY);
            let slow = accel.closest_hit_brute(&ray, 0.0, f64::INFINITY);
            assert!(slow.is_some(), "brute force must hit a wall along {dir:?}");
            assert_eq!(
                fast.map(|h| h.prim),
                slow.map(|h| h.prim),
                "direction {dir:?} from {origin:?}"
            );
            assert!(
                accel.occluded(origin, origin + 5.0 * dir, [None, None]),
                "occlusion along {dir:?}"
            );
        }
    }
}
