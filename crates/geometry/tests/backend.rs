//! The occlusion backend contract's CPU side: `Accel` as the reference `Occluder`,
//! the upload view (`Accel::export`, pinned CWBVH node layout) and `traversal_ray`.

use std::mem::{align_of, offset_of, size_of};

use glam::DVec3;
use rand::{RngExt, SeedableRng};
use rand_pcg::Pcg64;
use wavelux_geometry::backend::{
    CpuOcclusion, CwBvhNode, Occluder, OcclusionBackend, OcclusionStats, SlotKind,
};
use wavelux_geometry::*;

fn rv(r: &mut Pcg64, lo: f64, hi: f64) -> DVec3 {
    DVec3::new(
        r.random_range(lo..hi),
        r.random_range(lo..hi),
        r.random_range(lo..hi),
    )
}

fn scene(seed: u64) -> Vec<Primitive> {
    let mut r = Pcg64::seed_from_u64(seed);
    let mut prims: Vec<Primitive> = Vec::new();
    for _ in 0..300 {
        let c = rv(&mut r, -5.0, 5.0);
        if let Ok(t) = Triangle::new(
            c + rv(&mut r, -0.5, 0.5),
            c + rv(&mut r, -0.5, 0.5),
            c + rv(&mut r, -0.5, 0.5),
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
    let lp = [
        DVec3::ZERO,
        DVec3::X,
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::new(0.5, 0.3, 0.0),
        DVec3::Y,
    ];
    prims.push(ComplexPolygon::from_world_loops(&lp, &[]).unwrap().into());
    // A convex quadrilateral that is no parallelogram (exported as a quad).
    let quad = [
        DVec3::new(2.0, 0.0, 1.0),
        DVec3::new(3.0, 0.0, 1.0),
        DVec3::new(3.2, 1.5, 1.0),
        DVec3::new(1.9, 1.0, 1.0),
    ];
    prims.push(ComplexPolygon::from_world_loops(&quad, &[]).unwrap().into());
    prims
}

#[test]
fn cwbvh_node_layout_is_pinned() {
    // The GPU kernels read nodes as 20 u32 words at these byte offsets.
    assert_eq!(size_of::<CwBvhNode>(), 80);
    assert_eq!(align_of::<CwBvhNode>(), 4);
    assert_eq!(offset_of!(CwBvhNode, p), 0);
    assert_eq!(offset_of!(CwBvhNode, e), 12);
    assert_eq!(offset_of!(CwBvhNode, imask), 15);
    assert_eq!(offset_of!(CwBvhNode, child_base_idx), 16);
    assert_eq!(offset_of!(CwBvhNode, primitive_base_idx), 20);
    assert_eq!(offset_of!(CwBvhNode, child_meta), 24);
    assert_eq!(offset_of!(CwBvhNode, child_min_x), 32);
    assert_eq!(offset_of!(CwBvhNode, child_max_x), 40);
    assert_eq!(offset_of!(CwBvhNode, child_min_y), 48);
    assert_eq!(offset_of!(CwBvhNode, child_max_y), 56);
    assert_eq!(offset_of!(CwBvhNode, child_min_z), 64);
    assert_eq!(offset_of!(CwBvhNode, child_max_z), 72);
}

fn queries(seed: u64, n: usize, nprims: u32) -> Vec<OcclusionQuery> {
    let mut r = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|i| OcclusionQuery {
            p: rv(&mut r, -6.0, 6.0),
            q: rv(&mut r, -6.0, 6.0),
            ignore: if i % 3 == 0 {
                [Some(r.random_range(0..nprims)), None]
            } else {
                [None, None]
            },
        })
        .collect()
}

#[test]
fn accel_and_cpu_backend_answer_like_occluded() {
    let acc = Accel::build(scene(1)).unwrap();
    let qs = queries(2, 2000, acc.len() as u32);
    let mut a = vec![false; qs.len()];
    let stats = Occluder::occluded_queries(&acc, &qs, &mut a).unwrap();
    assert_eq!(
        stats,
        OcclusionStats {
            queries: qs.len(),
            device_rays: 0,
            deferred_rays: qs.len()
        }
    );
    let occ = CpuOcclusion.occluder(&acc).unwrap();
    let mut b = vec![true; qs.len()];
    occ.occluded_queries(&qs, &mut b).unwrap();
    let mut blocked = 0;
    for (i, q) in qs.iter().enumerate() {
        let want = acc.occluded(q.p, q.q, q.ignore);
        assert_eq!(a[i], want, "query {i}");
        assert_eq!(b[i], want, "query {i}");
        blocked += usize::from(want);
    }
    // Both answers occur (the test can fail either way).
    assert!(blocked > 100 && blocked < qs.len() - 100, "{blocked}");
    assert_eq!(CpuOcclusion.name(), "cpu");
    let mut short = vec![false; 3];
    assert!(matches!(
        occ.occluded_queries(&qs, &mut short),
        Err(GeometryError::OutOfRange { .. })
    ));
}

#[test]
fn export_lists_every_primitive_once_in_the_frame() {
    let prims = scene(3);
    let acc = Accel::build(prims.clone()).unwrap();
    let ex = acc.export();
    assert!(!ex.nodes.is_empty());
    assert_eq!(ex.slots.len(), prims.len());
    let mut seen = vec![false; prims.len()];
    for s in &ex.slots {
        assert!(!seen[s.prim as usize], "primitive {} twice", s.prim);
        seen[s.prim as usize] = true;
        let f = |x: DVec3| {
            let y = ex.frame.to_frame(x);
            [y.x as f32, y.y as f32, y.z as f32]
        };
        match &prims[s.prim as usize] {
            Primitive::Triangle(t) => {
                assert_eq!(s.kind, SlotKind::Triangle);
                for k in 0..3 {
                    assert_eq!(s.points[k], f(t.v[k]));
                }
            }
            Primitive::Parallelogram(g) => {
                assert_eq!(s.kind, SlotKind::Quad);
                for (k, c) in g.corners().iter().enumerate() {
                    assert_eq!(s.points[k], f(*c));
                }
            }
            // The five-sided test polygon has a reflex corner; the quad is convex.
            Primitive::Polygon(poly) => {
                if poly.region.loops[0].edges.len() == 4 {
                    assert_eq!(s.kind, SlotKind::Quad);
                    for k in 0..4 {
                        let p = s.points[k];
                        let d = DVec3::new(p[0] as f64, p[1] as f64, p[2] as f64)
                            - ex.frame.to_frame(poly.frame.to_world(
                                match &poly.region.loops[0].edges[k] {
                                    Edge2::Segment { a, .. } => *a,
                                    _ => unreachable!("straight quad"),
                                },
                            ));
                        assert!(d.length() < 1e-6, "{d:?}");
                    }
                } else {
                    assert_eq!(s.kind, SlotKind::Plane);
                }
            }
            _ => assert_eq!(s.kind, SlotKind::Curved),
        }
        assert!(s.planar);
        // Every exported point lies in the normalised scene box.
        for p in &s.points {
            assert!(p.iter().all(|c| c.abs() <= 0.5 + 1e-6), "{p:?}");
        }
    }
    // Scale is a power of two with diagonal·scale ∈ (½, 1].
    let d = acc.bounds().diagonal().length() * ex.frame.scale;
    assert!(d > 0.5 && d <= 1.0, "{d}");
    assert_eq!(ex.frame.scale.log2().fract(), 0.0);
    assert_eq!(ex.frame.eps, acc.eps());
    // Leaf slots reachable from the nodes cover every slot index exactly once.
    let mut count = vec![0u32; ex.slots.len()];
    for n in ex.nodes {
        for k in 0..8 {
            let m = n.child_meta[k];
            if m != 0 && n.imask & (1 << k) == 0 {
                let start = n.primitive_base_idx + u32::from(m & 0b11111);
                for j in 0..(m >> 5).count_ones() {
                    count[(start + j) as usize] += 1;
                }
            }
        }
    }
    assert!(count.iter().all(|&c| c == 1));
}

#[test]
fn export_of_an_empty_accel_is_empty() {
    let acc = Accel::build(Vec::new()).unwrap();
    let ex = acc.export();
    assert!(ex.nodes.is_empty() && ex.slots.is_empty());
    assert!(acc.traversal_ray(DVec3::ZERO, DVec3::X).is_none());
}

#[test]
fn traversal_ray_covers_the_segment_at_every_scale() {
    for scale in [1e-6, 1.0, 1e6] {
        let prims: Vec<Primitive> = scene(4)
            .into_iter()
            .filter_map(|p| match p {
                Primitive::Triangle(t) => {
                    Triangle::new(t.v[0] * scale, t.v[1] * scale, t.v[2] * scale)
                        .ok()
                        .map(Primitive::from)
                }
                _ => None,
            })
            .collect();
        let acc = Accel::build(prims).unwrap();
        let ex = acc.export();
        let mut r = Pcg64::seed_from_u64(5);
        for _ in 0..200 {
            let (p, q) = (rv(&mut r, -4.0, 4.0) * scale, rv(&mut r, -4.0, 4.0) * scale);
            let ray = acc
                .traversal_ray(p, q)
                .expect("segment inside the scene box");
            let (pn, qn) = (ex.frame.to_frame(p), ex.frame.to_frame(q));
            let o = DVec3::new(
                ray.origin.x as f64,
                ray.origin.y as f64,
                ray.origin.z as f64,
            );
            let d = DVec3::new(
                ray.direction.x as f64,
                ray.direction.y as f64,
                ray.direction.z as f64,
            );
            // The ray starts at or before p and reaches past q (normalised units).
            let tp = (pn - o).dot(d);
            let tq = (qn - o).dot(d);
            assert!(tp >= 0.0 && tq <= ray.tmax as f64, "{tp} {tq} {}", ray.tmax);
            assert!((o + d * tq - qn).length() < 1e-5, "scale {scale}");
        }
        assert!(acc.traversal_ray(DVec3::ONE, DVec3::ONE).is_none());
    }
}
