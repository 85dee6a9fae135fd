//! Tessellated baselines: area convergence against `Primitive::area`, vertices on the
//! exact surface, surface normals, watertightness inside the region, no triangle in a
//! hole, consistent orientation, typed errors on degenerate input.

use std::f64::consts::{FRAC_PI_2, PI, TAU};
use std::sync::Arc;

use glam::{DVec2, DVec3};
use proptest::prelude::*;
use wavelux_geometry::tessellate::{flatten_edge, tessellate_polygon};
use wavelux_geometry::{
    BezierPatch, ComplexPolygon, Edge2, GeometryError, Grid, Parallelogram, PlaneFrame, Primitive,
    RegionFault, TessellationError, TessellationOptions, Triangle, TriangleMesh, TrimLoop,
    TrimRegion, TrimmedPatch, tessellate, tessellate_all,
};
use wavelux_param::{Cylinder, Frame, Sphere};

/// Distance from `p` to an edge (exact for segments and arcs).
fn dist_edge(e: &Edge2, p: DVec2) -> f64 {
    match *e {
        Edge2::Segment { a, b } => {
            let d = b - a;
            let t = ((p - a).dot(d) / d.length_squared()).clamp(0.0, 1.0);
            (a + t * d - p).length()
        }
        Edge2::Arc {
            center,
            radius,
            start,
            sweep,
        } => {
            let th = (p - center).to_angle();
            let rel = if sweep > 0.0 {
                (th - start).rem_euclid(TAU)
            } else {
                (start - th).rem_euclid(TAU)
            };
            let ends = (e.start() - p).length().min((e.end() - p).length());
            if rel <= sweep.abs() {
                ((p - center).length() - radius).abs().min(ends)
            } else {
                ends
            }
        }
    }
}

fn dist_region(r: &TrimRegion, p: DVec2) -> f64 {
    r.loops
        .iter()
        .flat_map(|l| l.edges.iter())
        .map(|e| dist_edge(e, p))
        .fold(f64::INFINITY, f64::min)
}

/// Checks shared by every primitive: validation, vertices on the surface, surface
/// normals, orientation, watertightness (interior edges used twice, boundary edges only
/// on the region boundary given by `boundary_dist`), every triangle inside the region.
fn check_mesh(
    prim: &Primitive,
    m: &TriangleMesh,
    boundary_dist: impl Fn(DVec2) -> f64,
    boundary_tol: f64,
    inside: impl Fn(DVec2) -> bool,
) {
    check_mesh_mid(prim, m, boundary_dist, boundary_tol, inside, true);
}

/// [`check_mesh`]; `check_mid` also tests the parameter midpoint of boundary edges
/// (meaningful where the support map is affine along the boundary).
fn check_mesh_mid(
    prim: &Primitive,
    m: &TriangleMesh,
    boundary_dist: impl Fn(DVec2) -> f64,
    boundary_tol: f64,
    inside: impl Fn(DVec2) -> bool,
    check_mid: bool,
) {
    m.validate().unwrap();
    let size = prim.aabb().diagonal().length();
    for i in 0..m.vertex_count() {
        let d = (prim.eval(m.uvs[i]) - m.positions[i]).length();
        assert!(d <= 1e-12 * size, "vertex {i} off the surface by {d}");
        let dn = (prim.normal(m.uvs[i]) - m.normals[i]).length();
        assert!(dn <= 1e-12, "normal {i} differs by {dn}");
    }
    for t in 0..m.triangle_count() {
        let [a, b, c] = m.indices[t];
        let fc = m.face_cross(t);
        let nm = m.normals[a as usize] + m.normals[b as usize] + m.normals[c as usize];
        if fc.length() > 1e-10 * size * size {
            assert!(
                fc.dot(nm) > 0.0,
                "triangle {t} faces backwards: uv {:?} x {:?} n {:?} fc {fc}",
                [m.uvs[a as usize], m.uvs[b as usize], m.uvs[c as usize]],
                m.corners(t),
                [
                    m.normals[a as usize],
                    m.normals[b as usize],
                    m.normals[c as usize]
                ]
            );
        }
        let cu = (m.uvs[a as usize] + m.uvs[b as usize] + m.uvs[c as usize]) / 3.0;
        assert!(inside(cu), "triangle {t} centroid {cu} outside the region");
    }
    for (a, b) in m.boundary_edges() {
        let (qa, qb) = (m.uvs[a as usize], m.uvs[b as usize]);
        let qs = if check_mid {
            vec![qa, qb, 0.5 * (qa + qb)]
        } else {
            vec![qa, qb]
        };
        for q in qs {
            let d = boundary_dist(q);
            assert!(
                d <= boundary_tol,
                "boundary edge ({a},{b}) at {q} is {d} from the boundary"
            );
        }
    }
}

/// A star-shaped (non-convex) polygon with a star-shaped hole, in a random plane.
fn star_polygon(radii: &[f64], hole: &[f64], normal: DVec3, origin: DVec3) -> ComplexPolygon {
    let frame = PlaneFrame::from_normal(origin, normal).unwrap();
    let n = radii.len();
    let outer: Vec<DVec3> = (0..n)
        .map(|k| {
            let t = TAU * k as f64 / n as f64;
            frame.to_world(radii[k] * DVec2::new(t.cos(), t.sin()))
        })
        .collect();
    let h = hole.len();
    let inner: Vec<DVec3> = (0..h)
        .map(|k| {
            let t = TAU * k as f64 / h as f64;
            frame.to_world(0.3 * hole[k] * DVec2::new(t.cos(), t.sin()))
        })
        .collect();
    ComplexPolygon::from_world_loops(&outer, &[inner]).unwrap()
}

/// Polygon dispatch helper with the uv → plane-coordinate map for boundary checks.
fn polygon_checks(p: &ComplexPolygon, m: &TriangleMesh, tol: f64) {
    let (lo, hi) = p.region.bounds();
    let to_plane = |uv: DVec2| lo + uv * (hi - lo);
    let prim = Primitive::from(p.clone());
    check_mesh(
        &prim,
        m,
        |uv| dist_region(&p.region, to_plane(uv)),
        tol,
        |uv| p.region.contains_tol(to_plane(uv), tol),
    );
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// Straight-edged non-convex polygons with holes: the CDT area is exact (1e-12).
    #[test]
    fn straight_polygon_area_exact(
        radii in prop::collection::vec(0.6f64..1.0, 5..14),
        hole in prop::collection::vec(0.5f64..1.0, 3..8),
        nx in -1.0f64..1.0, ny in -1.0f64..1.0, nz in 0.2f64..1.0,
        grid in prop_oneof![Just(Grid::Adaptive), (1usize..12).prop_map(Grid::Uniform)],
        max_edge in prop::option::of(0.15f64..1.0),
    ) {
        let p = star_polygon(&radii, &hole, DVec3::new(nx, ny, nz), DVec3::new(1.0, -2.0, 0.5));
        let opts = TessellationOptions { grid, max_edge, ..Default::default() };
        let m = tessellate_polygon(&p, &opts).unwrap();
        let exact = p.area();
        prop_assert!((m.area() - exact).abs() <= 1e-12 * exact, "{} vs {}", m.area(), exact);
        polygon_checks(&p, &m, 1e-9);
        if let Some(e) = max_edge {
            // Boundary chords respect max_edge exactly.
            for (a, b) in m.boundary_edges() {
                prop_assert!((m.positions[a as usize] - m.positions[b as usize]).length() <= e * (1.0 + 1e-12));
            }
            // Interior: area ≤ (√3/4)e² and all angles ≥ 20° give edges ≤ 2.2 e.
            for (a, b) in m.edge_counts().keys() {
                prop_assert!((m.positions[*a as usize] - m.positions[*b as usize]).length() <= 2.2 * e);
            }
        }
    }
}

/// A disc of radius `r` with an off-centre circular hole and a square hole (arcs + segments).
fn arc_polygon(r: f64) -> ComplexPolygon {
    let outer = TrimLoop::new(vec![
        Edge2::arc(DVec2::ZERO, r, 0.0, PI).unwrap(),
        Edge2::segment(DVec2::new(-r, 0.0), DVec2::new(-r, -r)).unwrap(),
        Edge2::segment(DVec2::new(-r, -r), DVec2::new(r, -r)).unwrap(),
        Edge2::segment(DVec2::new(r, -r), DVec2::new(r, 0.0)).unwrap(),
    ])
    .unwrap();
    let hole = TrimLoop::circle(DVec2::new(0.3 * r, 0.3 * r), 0.25 * r)
        .unwrap()
        .reversed();
    let sq = TrimLoop::rect(
        DVec2::new(-0.6 * r, -0.8 * r),
        DVec2::new(-0.2 * r, -0.4 * r),
    )
    .unwrap()
    .reversed();
    let frame = PlaneFrame::from_axes(
        DVec3::new(0.2, 0.1, 3.0),
        DVec3::new(1.0, 1.0, 0.0),
        DVec3::Z,
    )
    .unwrap();
    ComplexPolygon::new(frame, TrimRegion::new(vec![outer, hole, sq]).unwrap()).unwrap()
}

#[test]
fn arc_polygon_area_within_chord_bound() {
    let p = arc_polygon(2.0);
    let exact = p.area();
    let (lo, hi) = p.region.bounds();
    let diag = (hi - lo).length();
    // Arc length of all arcs: the half disc's arc and the hole circle.
    let arc_len = PI * 2.0 + TAU * 0.5;
    let mut last = f64::INFINITY;
    for tol in [1e-2, 1e-3, 1e-4, 1e-5] {
        for grid in [Grid::Adaptive, Grid::Uniform(7)] {
            let opts = TessellationOptions {
                chord_tolerance: tol,
                grid,
                ..Default::default()
            };
            let m = tessellate_polygon(&p, &opts).unwrap();
            let err = (m.area() - exact).abs();
            // Each chord of length c with sagitta s cuts off a circular segment of area ≤ c·s.
            let bound = arc_len * tol * diag;
            assert!(err <= bound, "tol {tol}: err {err} > bound {bound}");
            polygon_checks(&p, &m, tol * diag * (1.0 + 1e-9));
            if grid == Grid::Adaptive {
                assert!(err < last);
                last = err;
            }
        }
    }
}

#[test]
fn flatten_edge_sagitta_bound() {
    let e = Edge2::arc(DVec2::new(0.3, -0.2), 1.7, 0.4, -5.0).unwrap();
    for tol in [1e-1, 1e-3, 1e-6] {
        let pts = flatten_edge(&e, tol, f64::INFINITY, 1 << 20).unwrap();
        let mut all = pts.clone();
        all.push(e.end());
        for w in all.windows(2) {
            let mid = 0.5 * (w[0] + w[1]);
            let sag = 1.7 - (mid - DVec2::new(0.3, -0.2)).length();
            assert!(sag <= tol * (1.0 + 1e-9) && sag > 0.0);
        }
        // Not over-refined: one piece fewer would violate the bound.
        let n = pts.len() as f64;
        let sag_fewer = 1.7 * (1.0 - (5.0 / (2.0 * (n - 1.0))).cos());
        assert!(n == 1.0 || sag_fewer > tol);
    }
}

fn sphere_patch(trim: Option<TrimRegion>, natural: bool) -> TrimmedPatch {
    let f = Frame::new(
        DVec3::new(0.5, 0.0, -1.0),
        DVec3::new(0.2, 0.1, 1.0),
        DVec3::X,
    )
    .unwrap();
    let s = Sphere::new(f, 1.3, (-2.5, 1.9), (-1.0, 1.2)).unwrap();
    let s = if natural { s.natural() } else { s };
    TrimmedPatch::new(Arc::new(s), trim).unwrap()
}

fn disc_trim() -> TrimRegion {
    let outer = TrimLoop::rect(DVec2::new(0.05, 0.1), DVec2::new(0.95, 0.9)).unwrap();
    let hole = TrimLoop::circle(DVec2::new(0.45, 0.5), 0.2)
        .unwrap()
        .reversed();
    TrimRegion::new(vec![outer, hole]).unwrap()
}

fn patch_checks(p: &TrimmedPatch, m: &TriangleMesh, tol: f64) {
    let prim = Primitive::from(p.clone());
    let sq = TrimRegion::unit_square().unwrap();
    let region = p.trim.clone().unwrap_or(sq);
    check_mesh(
        &prim,
        m,
        |uv| dist_region(&region, uv),
        tol,
        |uv| region.contains_tol(uv, tol),
    );
}

/// Observed convergence order of the area error for n, 2n, 4n.
fn orders(errs: &[f64]) -> Vec<f64> {
    errs.windows(2).map(|w| (w[0] / w[1]).log2()).collect()
}

#[test]
fn curved_patch_area_converges_second_order() {
    for natural in [false, true] {
        for trim in [None, Some(disc_trim())] {
            let p = sphere_patch(trim.clone(), natural);
            let exact = Primitive::from(p.clone()).area();
            let mut errs = Vec::new();
            for n in [8, 16, 32, 64] {
                // Trim arcs flattened with sagitta ∝ h² keep the boundary error O(h²) too.
                let tol = 0.5 / (n * n) as f64;
                let opts = TessellationOptions {
                    chord_tolerance: tol,
                    ..TessellationOptions::uniform(n)
                };
                let m = tessellate(&Primitive::from(p.clone()), &opts).unwrap();
                patch_checks(&p, &m, tol * (1.0 + 1e-9));
                errs.push((m.area() - exact).abs() / exact);
            }
            let o = orders(&errs);
            // Flat triangles inscribed in a smooth surface: error O(h²).
            assert!(errs.windows(2).all(|w| w[1] < w[0]), "{errs:?}");
            // Structured grids converge at exactly order 2 pair by pair; with a trim the
            // CDT near the boundary makes single steps noisy, the overall order is ~2.
            let overall = (errs[0] / errs[3]).log2() / 3.0;
            let pair_min = if trim.is_some() { 1.0 } else { 1.9 };
            assert!(
                overall > 1.8 && o.iter().all(|&k| k > pair_min),
                "natural {natural}, trim {}: orders {o:?} errs {errs:?}",
                trim.is_some()
            );
        }
    }
}

fn bezier() -> BezierPatch {
    let mut p = [[DVec3::ZERO; 4]; 4];
    for (i, row) in p.iter_mut().enumerate() {
        for (j, q) in row.iter_mut().enumerate() {
            let (x, y) = (i as f64 / 3.0, j as f64 / 3.0);
            *q = DVec3::new(
                2.0 * x,
                1.5 * y + 0.2 * x,
                0.6 * ((3.0 * x).sin() * (2.0 * y).cos()) + 0.3 * x * y,
            );
        }
    }
    BezierPatch::new(p).unwrap()
}

#[test]
fn bezier_area_converges_and_adaptive_is_tighter() {
    let b = bezier();
    let prim = Primitive::from(b);
    let exact = prim.area();
    let sq = TrimRegion::unit_square().unwrap();
    let mut errs = Vec::new();
    for n in [6, 12, 24, 48] {
        let m = tessellate(&prim, &TessellationOptions::uniform(n)).unwrap();
        check_mesh(
            &prim,
            &m,
            |uv| dist_region(&sq, uv),
            1e-12,
            |uv| sq.contains_tol(uv, 1e-12),
        );
        errs.push((m.area() - exact).abs() / exact);
    }
    assert!(orders(&errs).iter().all(|&k| k > 1.6), "{errs:?}");
    let mut last = (f64::INFINITY, 0usize);
    for tol in [1e-2, 1e-3, 1e-4] {
        let m = tessellate(&prim, &TessellationOptions::adaptive(tol)).unwrap();
        check_mesh(
            &prim,
            &m,
            |uv| dist_region(&sq, uv),
            1e-12,
            |uv| sq.contains_tol(uv, 1e-12),
        );
        let err = (m.area() - exact).abs() / exact;
        assert!(
            err < last.0 && m.triangle_count() > last.1,
            "tol {tol}: {err}"
        );
        last = (err, m.triangle_count());
    }
}

#[test]
fn trimmed_cylinder_adaptive_and_watertight() {
    let f = Frame::canonical();
    let c = Cylinder::new(f, 0.8, (0.0, 4.0), (-1.0, 1.5)).unwrap();
    let trim = TrimRegion::new(vec![
        TrimLoop::new(vec![
            Edge2::arc(DVec2::new(0.5, 0.5), 0.45, 0.0, TAU).unwrap(),
        ])
        .unwrap(),
        TrimLoop::rect(DVec2::new(0.3, 0.3), DVec2::new(0.5, 0.6))
            .unwrap()
            .reversed(),
    ])
    .unwrap();
    let p = TrimmedPatch::new(Arc::new(c.natural()), Some(trim)).unwrap();
    let exact = p.area();
    for tol in [1e-3, 1e-4] {
        let opts = TessellationOptions {
            max_edge: Some(0.3),
            ..TessellationOptions::adaptive(tol)
        };
        let m = tessellate(&Primitive::from(p.clone()), &opts).unwrap();
        patch_checks(&p, &m, tol * (1.0 + 1e-9));
        let rel = (m.area() - exact).abs() / exact;
        assert!(rel < 50.0 * tol, "tol {tol}: rel {rel}");
        // Every interior edge is shared by exactly two triangles; the boundary has as
        // many edges as vertices (closed loops), two loops here.
        let be = m.boundary_edges();
        let mut deg = std::collections::HashMap::new();
        for (a, b) in &be {
            *deg.entry(*a).or_insert(0) += 1;
            *deg.entry(*b).or_insert(0) += 1;
        }
        assert!(
            deg.values().all(|&d| d == 2),
            "boundary is not a union of closed loops"
        );
    }
}

#[test]
fn triangle_and_parallelogram_exact() {
    let t = Triangle::new(
        DVec3::new(0.0, 0.0, 1.0),
        DVec3::new(2.0, 0.3, 0.0),
        DVec3::new(-0.5, 1.7, 0.4),
    )
    .unwrap();
    let q = Parallelogram::new(
        DVec3::new(1.0, 2.0, 3.0),
        DVec3::new(1.0, 0.5, 0.0),
        DVec3::new(-0.2, 0.3, 1.1),
    )
    .unwrap();
    let sq = TrimRegion::unit_square().unwrap();
    for n in [1, 2, 5, 9] {
        let pt = Primitive::from(t);
        let m = tessellate(&pt, &TessellationOptions::uniform(n)).unwrap();
        assert_eq!(m.triangle_count(), n * n);
        assert!((m.area() - t.area()).abs() <= 1e-13 * t.area());
        // Triangle support: edges are v = 0, v = 1 (through the apex u = 0) and u = 1.
        check_mesh_mid(
            &pt,
            &m,
            |uv| uv.y.min(1.0 - uv.y).min(1.0 - uv.x).abs(),
            1e-12,
            |uv| sq.contains_tol(uv, 1e-12),
            false,
        );
        let pq = Primitive::from(q);
        let m = tessellate(&pq, &TessellationOptions::uniform(n)).unwrap();
        assert_eq!(m.triangle_count(), 2 * n * n);
        assert!((m.area() - q.area()).abs() <= 1e-13 * q.area());
        check_mesh(
            &pq,
            &m,
            |uv| dist_region(&sq, uv),
            1e-12,
            |uv| sq.contains_tol(uv, 1e-12),
        );
    }
}

#[test]
fn tessellate_all_back_references() {
    let prims = vec![
        Primitive::from(arc_polygon(1.0)),
        Primitive::from(bezier()),
        Primitive::from(sphere_patch(Some(disc_trim()), false)),
        Primitive::from(Parallelogram::new(DVec3::ZERO, DVec3::X, DVec3::Y).unwrap()),
    ];
    let opts = |i: usize, _: &Primitive| {
        if i.is_multiple_of(2) {
            TessellationOptions::adaptive(1e-3)
        } else {
            TessellationOptions::uniform(10)
        }
    };
    let all = tessellate_all(&prims, opts).unwrap();
    assert_eq!(all.len(), prims.len());
    for (k, pm) in all.iter().enumerate() {
        assert_eq!(pm.prim, k);
        let single = tessellate(&prims[k], &opts(k, &prims[k])).unwrap();
        assert_eq!(single, pm.mesh, "deterministic and order independent");
    }
}

#[test]
fn degenerate_input_gives_typed_errors() {
    let p = arc_polygon(1.0);
    let bad = [
        TessellationOptions {
            chord_tolerance: f64::NAN,
            ..Default::default()
        },
        TessellationOptions {
            chord_tolerance: 0.0,
            ..Default::default()
        },
        TessellationOptions::uniform(0),
        TessellationOptions {
            max_edge: Some(-1.0),
            ..Default::default()
        },
        TessellationOptions {
            max_edge: Some(f64::INFINITY),
            ..Default::default()
        },
    ];
    for o in bad {
        assert!(matches!(
            tessellate_polygon(&p, &o),
            Err(TessellationError::InvalidOptions(_))
        ));
    }
    // Crossing loops (two overlapping squares) no longer reach the tessellator: the
    // region itself is refused, naming the pair.
    let a = TrimLoop::rect(DVec2::ZERO, DVec2::splat(1.0)).unwrap();
    let b = TrimLoop::rect(DVec2::splat(0.5), DVec2::splat(1.5)).unwrap();
    assert_eq!(
        TrimRegion::new(vec![a, b]),
        Err(GeometryError::Region(RegionFault::Overlap { a: 0, b: 1 }))
    );
    // Vertex budget.
    let o = TessellationOptions {
        max_vertices: 50,
        ..TessellationOptions::uniform(64)
    };
    assert!(matches!(
        tessellate_polygon(&p, &o),
        Err(TessellationError::TooLarge(50))
    ));
    let o = TessellationOptions {
        max_vertices: 50,
        ..TessellationOptions::adaptive(1e-6)
    };
    assert!(matches!(
        tessellate(&Primitive::from(bezier()), &o),
        Err(TessellationError::TooLarge(50))
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Arbitrary option values never panic: they either tessellate validly or return an error.
    #[test]
    fn arbitrary_options_never_panic(
        tol in prop_oneof![Just(f64::NAN), Just(-1.0), 1e-12f64..2.0],
        n in 0usize..40,
        adaptive in any::<bool>(),
        max_edge in prop::option::of(prop_oneof![Just(0.0), Just(f64::NAN), 0.05f64..5.0]),
        depth in 0u32..14,
        which in 0usize..3,
        angle in prop_oneof![Just(0.0), Just(f64::NAN), 0.0f64..35.0],
    ) {
        let prim = match which {
            0 => Primitive::from(arc_polygon(1.0)),
            1 => Primitive::from(bezier()),
            _ => Primitive::from(sphere_patch(Some(disc_trim()), true)),
        };
        let opts = TessellationOptions {
            chord_tolerance: tol,
            max_edge,
            grid: if adaptive { Grid::Adaptive } else { Grid::Uniform(n) },
            max_depth: depth,
            max_vertices: 20_000,
            min_angle_deg: angle,
        };
        if let Ok(m) = tessellate(&prim, &opts) {
            prop_assert!(m.validate().is_ok());
            prop_assert!(m.triangle_count() > 0);
        }
    }
}

#[test]
fn full_sphere_and_half_pi_latitudes() {
    // Poles collapse a grid row to one point: zero-area triangles are allowed, the mesh
    // must still validate and converge in area.
    let s = Sphere::new(Frame::canonical(), 1.0, (-PI, PI), (-FRAC_PI_2, FRAC_PI_2)).unwrap();
    let p = TrimmedPatch::new(Arc::new(s), None).unwrap();
    let exact = p.area();
    let mut errs = Vec::new();
    for n in [8, 16, 32] {
        let m = tessellate(
            &Primitive::from(p.clone()),
            &TessellationOptions::uniform(n),
        )
        .unwrap();
        m.validate().unwrap();
        errs.push((m.area() - exact).abs() / exact);
    }
    assert!(errs.windows(2).all(|w| w[1] < 0.5 * w[0]), "{errs:?}");
}

/// Adaptive meshes meet the chordal tolerance: at every triangle's parameter centroid the
/// surface lies within `chord_tolerance · diag` of the flat triangle's centroid.
#[test]
fn adaptive_meets_chordal_tolerance() {
    let prims = [
        Primitive::from(bezier()),
        Primitive::from(sphere_patch(Some(disc_trim()), true)),
        Primitive::from(sphere_patch(None, false)),
    ];
    for prim in &prims {
        let diag = prim.aabb().diagonal().length();
        let mut count = 0;
        for tol in [1e-2, 1e-3, 1e-4] {
            let m = tessellate(prim, &TessellationOptions::adaptive(tol)).unwrap();
            let mut worst: f64 = 0.0;
            for t in 0..m.triangle_count() {
                let [a, b, c] = m.indices[t].map(|i| i as usize);
                let cu = (m.uvs[a] + m.uvs[b] + m.uvs[c]) / 3.0;
                let cx = (m.positions[a] + m.positions[b] + m.positions[c]) / 3.0;
                worst = worst.max((prim.eval(cu) - cx).length());
            }
            assert!(
                worst <= tol * diag,
                "tol {tol}: worst deviation {worst} > {}",
                tol * diag
            );
            assert!(m.triangle_count() > count);
            count = m.triangle_count();
        }
    }
}

/// Adaptive quadtree cells outside a small trim are dropped: a trim covering ~3% of the
/// parameter square costs far fewer vertices than the untrimmed patch, and the area of
/// the trimmed mesh still matches `Primitive::area`.
#[test]
fn adaptive_drops_cells_outside_trim() {
    let small =
        TrimRegion::new(vec![TrimLoop::circle(DVec2::new(0.3, 0.6), 0.1).unwrap()]).unwrap();
    let full = sphere_patch(None, true);
    let part = sphere_patch(Some(small), true);
    let o = TessellationOptions::adaptive(1e-4);
    let mf = tessellate(&Primitive::from(full), &o).unwrap();
    let mp = tessellate(&Primitive::from(part.clone()), &o).unwrap();
    patch_checks(&part, &mp, 1e-4 * (1.0 + 1e-9));
    assert!(
        mp.vertex_count() * 5 < mf.vertex_count(),
        "{} vs {}",
        mp.vertex_count(),
        mf.vertex_count()
    );
    let exact = part.area();
    assert!((mp.area() - exact).abs() / exact < 2e-3);
}

/// `max_edge` raises the resolution of uniform grids on curved patches: grid edges along
/// `u` and `v` are at most ≈ `max_edge`, cell diagonals at most ≈ √2 · `max_edge`.
#[test]
fn uniform_curved_respects_max_edge() {
    let prim = Primitive::from(bezier());
    for e in [0.3, 0.1, 0.05] {
        let o = TessellationOptions {
            max_edge: Some(e),
            ..TessellationOptions::uniform(2)
        };
        let m = tessellate(&prim, &o).unwrap();
        let longest = m
            .edge_counts()
            .keys()
            .map(|&(a, b)| (m.positions[a as usize] - m.positions[b as usize]).length())
            .fold(0.0, f64::max);
        assert!(longest <= 1.5 * e, "max_edge {e}: longest edge {longest}");
        assert!(
            longest >= 0.5 * e,
            "max_edge {e}: over-refined, longest edge {longest}"
        );
    }
}
