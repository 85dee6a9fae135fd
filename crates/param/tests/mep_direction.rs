//! Minimal enclosing parallelograms (VirtualMesh §3.2) against brute force, and the
//! direction maps (Glossy §3.3, Shirley–Chiu, octahedral) for Jacobians and inverses.

mod common;

use common::{fd, rng};
use glam::{DVec2, DVec3};
use proptest::prelude::*;
use rand::RngExt;
use std::f64::consts::{FRAC_PI_2, PI, TAU};
use wavelux_param::{
    BoundarySegment, ConcentricHemisphere, DirectionMap, GlossyHemisphere, OctahedralSphere,
    Parallelogram2, ParamError, convex_hull, min_enclosing_parallelogram,
    min_enclosing_parallelogram_of_boundary,
};
use wavelux_quadrature::GaussLegendre;

fn cross(a: DVec2, b: DVec2) -> f64 {
    a.x * b.y - a.y * b.x
}

/// Width of the point set across unit direction `d` (extent along its normal).
fn width(points: &[DVec2], d: DVec2) -> f64 {
    let n = DVec2::new(-d.y, d.x);
    let (lo, hi) = points
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), p| {
            (l.min(n.dot(*p)), h.max(n.dot(*p)))
        });
    hi - lo
}

/// Brute force: every strip direction through two input points, every pair of them.
fn brute_force(points: &[DVec2]) -> f64 {
    let mut dirs = Vec::new();
    for i in 0..points.len() {
        for j in (i + 1)..points.len() {
            if let Some(d) = (points[j] - points[i]).try_normalize() {
                dirs.push(d);
            }
        }
    }
    let w: Vec<f64> = dirs.iter().map(|d| width(points, *d)).collect();
    let mut best = f64::INFINITY;
    for i in 0..dirs.len() {
        for k in (i + 1)..dirs.len() {
            let s = cross(dirs[i], dirs[k]).abs();
            if s > 1e-12 {
                best = best.min(w[i] * w[k] / s);
            }
        }
    }
    best
}

fn assert_encloses(p: &Parallelogram2, pts: &[DVec2]) {
    for q in pts {
        assert!(p.contains(*q, 1e-9), "{q} outside {p:?}");
    }
}

#[test]
fn mep_matches_brute_force_on_random_sets() {
    let mut r = rng(21);
    for case in 0..60usize {
        let n = 3 + case % 25;
        let scale = 10f64.powi((case % 9) as i32 - 4);
        let stretch = 1.0 + 9.0 * r.random::<f64>();
        let pts: Vec<DVec2> = (0..n)
            .map(|_| DVec2::new(r.random::<f64>() * stretch, r.random::<f64>()) * scale)
            .collect();
        let p = min_enclosing_parallelogram(&pts).unwrap();
        assert!(cross(p.e1, p.e2) > 0.0);
        assert_encloses(&p, &pts);
        let bf = brute_force(&pts);
        assert!(
            (p.area() - bf).abs() <= 1e-9 * bf,
            "case {case}: ours {} brute {bf}",
            p.area()
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    /// No pair of strip directions sampled at random beats the result.
    #[test]
    fn mep_not_beaten_by_random_directions(
        pts in prop::collection::vec((-5.0f64..5.0, -5.0f64..5.0), 3..30),
        angles in prop::collection::vec((0.0f64..PI, 0.0f64..PI), 50),
    ) {
        let pts: Vec<DVec2> = pts.into_iter().map(|(x, y)| DVec2::new(x, y)).collect();
        let Ok(p) = min_enclosing_parallelogram(&pts) else { return Ok(()); };
        for (a, b) in angles {
            let (da, db) = (DVec2::new(a.cos(), a.sin()), DVec2::new(b.cos(), b.sin()));
            let s = cross(da, db).abs();
            if s < 1e-6 { continue; }
            let area = width(&pts, da) * width(&pts, db) / s;
            prop_assert!(area >= p.area() * (1.0 - 1e-12));
        }
    }
}

#[test]
fn mep_closed_forms() {
    // A parallelogram is its own minimum.
    let sq = [
        DVec2::ZERO,
        DVec2::new(2.0, 0.0),
        DVec2::new(3.0, 1.0),
        DVec2::new(1.0, 1.0),
    ];
    assert!((min_enclosing_parallelogram(&sq).unwrap().area() - 2.0).abs() < 1e-14);
    // A triangle's minimal enclosing parallelogram has twice its area.
    let tri = [DVec2::ZERO, DVec2::new(4.0, 0.3), DVec2::new(1.0, 2.5)];
    let t_area = 0.5 * cross(tri[1] - tri[0], tri[2] - tri[0]).abs();
    assert!((min_enclosing_parallelogram(&tri).unwrap().area() - 2.0 * t_area).abs() < 1e-13);
    // A regular hexagon (unit circumradius): best is the 2×√3-wide strip pair at 60°,
    // area √3·√3 / sin 60° = 2√3.
    let hex: Vec<DVec2> = (0..6)
        .map(|k| DVec2::new((k as f64 * PI / 3.0).cos(), (k as f64 * PI / 3.0).sin()))
        .collect();
    let hp = min_enclosing_parallelogram(&hex).unwrap();
    assert!(
        (hp.area() - 2.0 * 3f64.sqrt()).abs() < 1e-13,
        "{}",
        hp.area()
    );
    // Interior and duplicate points change nothing.
    let mut more = hex.clone();
    more.extend([DVec2::ZERO, DVec2::new(0.1, 0.2), hex[0], hex[3]]);
    assert!((min_enclosing_parallelogram(&more).unwrap().area() - hp.area()).abs() < 1e-13);
    assert_eq!(convex_hull(&more).len(), 6);
}

#[test]
fn mep_of_thin_sets() {
    // Nearly collinear points (angles ~1e-6 rad) still give a valid enclosure.
    let pts = [
        DVec2::new(0.0, 0.0),
        DVec2::new(1.0, 1e-6),
        DVec2::new(2.0, 0.0),
        DVec2::new(1.0, -1e-6),
    ];
    let p = min_enclosing_parallelogram(&pts).unwrap();
    assert!((p.area() - 2e-6).abs() < 1e-15, "{}", p.area());
    assert_encloses(&p, &pts);
}

#[test]
fn mep_errors() {
    assert!(matches!(
        min_enclosing_parallelogram(&[DVec2::ZERO, DVec2::X]),
        Err(ParamError::TooFewPoints { .. })
    ));
    assert!(matches!(
        min_enclosing_parallelogram(&[DVec2::ZERO, DVec2::X, DVec2::X * 2.0]),
        Err(ParamError::Degenerate(_))
    ));
    let arc = BoundarySegment::Arc {
        centre: DVec2::ZERO,
        radius: -1.0,
        start: 0.0,
        sweep: 1.0,
    };
    assert!(min_enclosing_parallelogram_of_boundary(&[arc], 1e-3).is_err());
}

#[test]
fn mep_of_a_circle_is_the_circumscribed_square() {
    for &r in &[1e-3, 1.0, 1e3] {
        let tol = 1e-7 * r;
        let circle = BoundarySegment::Arc {
            centre: DVec2::new(3.0, -2.0) * r,
            radius: r,
            start: 0.3,
            sweep: TAU,
        };
        let p = min_enclosing_parallelogram_of_boundary(&[circle], tol).unwrap();
        // Any circumscribed parallelogram has area 4r²/sin α ≥ 4r².
        assert!(p.area() >= 4.0 * r * r * (1.0 - 1e-12));
        assert!(
            p.area() <= 4.0 * r * r * (1.0 + 1e-6),
            "{}",
            p.area() / (r * r)
        );
        let pts: Vec<DVec2> = (0..1000)
            .map(|k| DVec2::new(3.0, -2.0) * r + DVec2::from_angle(k as f64 * TAU / 1000.0) * r)
            .collect();
        assert_encloses(&p, &pts);
    }
}

#[test]
fn mep_of_a_polygon_with_arcs() {
    // A "D": a segment and a half circle, plus a rounded corner.
    let segs = [
        BoundarySegment::Line {
            from: DVec2::new(0.0, -1.0),
            to: DVec2::new(0.0, 1.0),
        },
        BoundarySegment::Arc {
            centre: DVec2::ZERO,
            radius: 1.0,
            start: FRAC_PI_2,
            sweep: -PI,
        },
        BoundarySegment::Arc {
            centre: DVec2::new(-0.5, 0.5),
            radius: 0.5,
            start: FRAC_PI_2,
            sweep: FRAC_PI_2,
        },
    ];
    let p = min_enclosing_parallelogram_of_boundary(&segs, 1e-8).unwrap();
    // Dense samples of the exact boundary: enclosed, and their own minimum is below ours
    // by at most O(tolerance).
    let mut dense = vec![DVec2::new(0.0, -1.0), DVec2::new(0.0, 1.0)];
    for k in 0..=4000 {
        let t = k as f64 / 4000.0;
        dense.push(DVec2::from_angle(FRAC_PI_2 - PI * t));
        dense.push(DVec2::new(-0.5, 0.5) + DVec2::from_angle(FRAC_PI_2 + FRAC_PI_2 * t) * 0.5);
    }
    assert_encloses(&p, &dense);
    let sampled = min_enclosing_parallelogram(&dense).unwrap().area();
    assert!(p.area() >= sampled * (1.0 - 1e-12));
    assert!(
        p.area() <= sampled * (1.0 + 1e-6),
        "{} vs {sampled}",
        p.area()
    );
}

// ---------------------------------------------------------------- direction maps

fn check_direction_map(m: &dyn DirectionMap, margin: f64, seam: impl Fn(DVec2) -> f64, seed: u64) {
    let mut r = rng(seed);
    let dir = |uv: DVec2| m.direction(uv);
    let mut done = 0;
    while done < 400 {
        let uv = DVec2::new(
            r.random_range(margin..1.0 - margin),
            r.random_range(margin..1.0 - margin),
        );
        let dist = seam(uv);
        if dist < 0.01 {
            continue;
        }
        done += 1;
        let d = m.direction(uv);
        assert!((d.length() - 1.0).abs() < 1e-14);
        let back = m.inverse(d).unwrap();
        assert!(
            (back - uv).abs().max_element() < 1e-12,
            "{uv} -> {d} -> {back}"
        );
        assert!((m.direction(back) - d).length() < 1e-14);
        let h = 1e-3 * dist.min(0.05);
        let j = fd(&dir, uv, DVec2::X, h)
            .cross(fd(&dir, uv, DVec2::Y, h))
            .length();
        let ja = m.jacobian(uv);
        assert!((j - ja).abs() <= 1e-9 * ja, "{uv}: FD {j} vs {ja}");
        if m.is_equal_area() {
            assert!((ja - m.solid_angle()).abs() <= 1e-14 * ja);
        }
    }
}

/// Distance to the diagonals, axes, centre and edges of the square (the maps' kinks).
fn square_seams(uv: DVec2) -> f64 {
    let q = uv * 2.0 - 1.0;
    let diag = (q.x.abs() - q.y.abs()).abs() / 2f64.sqrt();
    let axes = q.x.abs().min(q.y.abs());
    let edge = (1.0 - q.x.abs()).min(1.0 - q.y.abs());
    diag.min(axes).min(edge) * 0.5
}

#[test]
fn glossy_hemisphere_map() {
    let m = GlossyHemisphere;
    check_direction_map(&m, 0.0, square_seams, 31);
    // Centre → pole; square boundary → horizon; polar angle ∝ L∞ radius (arc length
    // along great circles through the pole is preserved).
    assert!((m.direction(DVec2::splat(0.5)) - DVec3::Z).length() < 1e-15);
    for k in 0..=16 {
        let t = k as f64 / 16.0;
        assert!(m.direction(DVec2::new(t, 1.0)).z.abs() < 1e-15);
        let d = m.direction(DVec2::new(0.5 + 0.5 * t, 0.5 + 0.2 * t));
        assert!((d.z.acos() - t * FRAC_PI_2).abs() < 1e-14);
    }
    assert!(m.inverse(DVec3::new(0.0, 0.3, -0.1)).is_none());
    // Total solid angle: in each of the 4 triangles q = ρ(1, t) (rotated), dq = ρ dρ dt.
    let gl = GaussLegendre::new(40).unwrap();
    let (rs, rw) = gl.on_interval(0.0, 1.0).unwrap();
    let (ts, tw) = gl.on_interval(-1.0, 1.0).unwrap();
    let mut total = 0.0;
    for (rho, wr) in rs.iter().zip(&rw) {
        for (t, wt) in ts.iter().zip(&tw) {
            let uv = (DVec2::new(*rho, rho * t) + 1.0) * 0.5;
            total += wr * wt * rho * m.jacobian(uv);
        }
    }
    // du dv = dq/4 per triangle, four triangles.
    assert!((total - TAU).abs() < 1e-12, "{total}");
}

#[test]
fn concentric_hemisphere_map() {
    let m = ConcentricHemisphere;
    check_direction_map(&m, 0.0, square_seams, 32);
    assert!(m.inverse(DVec3::new(0.0, 0.0, -1.0)).is_none());
    assert_eq!(m.inverse(DVec3::Z), Some(DVec2::splat(0.5)));
    // Directions grazing the pole invert without cancellation.
    let d = DVec3::new(1e-9, 2e-9, 1.0).normalize();
    let uv = m.inverse(d).unwrap();
    assert!((m.direction(uv) - d).length() < 1e-15);
}

#[test]
fn octahedral_sphere_map() {
    let m = OctahedralSphere;
    let seams = |uv: DVec2| {
        let q = uv * 2.0 - 1.0;
        let fold = (q.x.abs() + q.y.abs() - 1.0).abs() / 2f64.sqrt();
        let axes = q.x.abs().min(q.y.abs());
        let edge = (1.0 - q.x.abs()).min(1.0 - q.y.abs());
        fold.min(axes).min(edge) * 0.5
    };
    check_direction_map(&m, 0.0, seams, 33);
    // Both poles and the equator.
    assert!((m.direction(DVec2::splat(0.5)) - DVec3::Z).length() < 1e-15);
    assert!((m.direction(DVec2::ZERO) + DVec3::Z).length() < 1e-15);
    assert!(m.direction(DVec2::new(1.0, 0.5)).z.abs() < 1e-15);
    // Every direction of a random set inverts.
    let mut r = rng(5);
    for _ in 0..1000 {
        let d = DVec3::new(
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
            r.random_range(-1.0..1.0),
        );
        let Some(dn) = d.try_normalize() else {
            continue;
        };
        let uv = m.inverse(dn).unwrap();
        assert!((m.direction(uv) - dn).length() < 1e-14, "{dn}");
    }
}
