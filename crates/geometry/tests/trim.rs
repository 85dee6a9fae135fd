//! Slab-decomposition trimming test vs brute-force winding numbers.

use glam::DVec2;
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};
use wavelux_geometry::{Edge2, TrimLoop, TrimRegion};

/// A star-shaped outer loop whose edges alternate between segments and arcs bulging
/// outwards or inwards, plus a circular hole and a polygonal (clockwise) hole.
fn region(radii: &[f64], bulge: &[f64], hole_r: f64) -> TrimRegion {
    let n = radii.len();
    let c = DVec2::splat(0.5);
    let pts: Vec<DVec2> = (0..n)
        .map(|k| {
            let t = TAU * k as f64 / n as f64;
            c + 0.45 * radii[k] * DVec2::new(t.cos(), t.sin())
        })
        .collect();
    let mut edges = Vec::new();
    for k in 0..n {
        let (a, b) = (pts[k], pts[(k + 1) % n]);
        let bl = bulge[k];
        if bl.abs() < 0.2 {
            edges.push(Edge2::segment(a, b).unwrap());
        } else {
            // Arc through a and b with sagitta angle: sweep = 2·bl (|bl| < π/2 keeps it small).
            let sweep = bl;
            let chord = b - a;
            let half = 0.5 * chord.length();
            let r = half / (0.5 * sweep.abs()).sin();
            let m = 0.5 * (a + b);
            let nrm = DVec2::new(-chord.y, chord.x).normalize();
            let d = r * (0.5 * sweep.abs()).cos();
            // Counter-clockwise arc (positive sweep) bulges to the right of a→b.
            let center = if sweep > 0.0 {
                m + d * nrm
            } else {
                m - d * nrm
            };
            let start = (a - center).to_angle();
            edges.push(Edge2::arc(center, r, start, sweep).unwrap());
        }
    }
    let outer = TrimLoop::new(edges).unwrap();
    // Disjoint holes: a circle right of the centre, a clockwise square left of it.
    let hole1 = TrimLoop::circle(c + DVec2::new(0.05, 0.0), hole_r)
        .unwrap()
        .reversed();
    let hole2 = TrimLoop::polygon(&[
        c + DVec2::new(-0.15, -0.03),
        c + DVec2::new(-0.15, 0.03),
        c + DVec2::new(-0.08, 0.03),
        c + DVec2::new(-0.08, -0.03),
    ])
    .unwrap();
    TrimRegion::new(vec![outer, hole1, hole2]).unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]
    #[test]
    fn slab_winding_equals_brute_force(
        radii in prop::collection::vec(0.6f64..1.0, 5..12),
        bulge_seed in prop::collection::vec(-1.2f64..1.2, 12),
        hole_r in 0.04f64..0.08,
        pts in prop::collection::vec((0.0f64..1.0, 0.0f64..1.0), 200),
    ) {
        let bulge: Vec<f64> = (0..radii.len()).map(|k| bulge_seed[k]).collect();
        // Keep inward arcs shallow so loops stay simple.
        let bulge: Vec<f64> = bulge.iter().map(|&b| if b < 0.0 { b * 0.3 } else { b }).collect();
        let reg = region(&radii, &bulge, hole_r);
        for (x, y) in pts {
            let p = DVec2::new(x, y);
            prop_assert_eq!(reg.winding(p), reg.winding_brute(p), "at {:?}", p);
        }
    }
}

#[test]
fn area_matches_grid_count_and_circle_closed_form() {
    let reg = region(
        &[1.0, 0.8, 0.9, 0.7, 1.0, 0.85],
        &[0.0, 1.0, -0.3, 0.5, 0.0, 0.9],
        0.07,
    );
    let n = 1000;
    let mut inside = 0usize;
    for i in 0..n {
        for j in 0..n {
            let p = DVec2::new((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            inside += usize::from(reg.contains(p));
        }
    }
    let grid = inside as f64 / (n * n) as f64;
    assert!((grid - reg.area()).abs() < 2e-3, "{grid} vs {}", reg.area());
    let disk = TrimRegion::new(vec![TrimLoop::circle(DVec2::splat(0.5), 0.3).unwrap()]).unwrap();
    assert!((disk.area() - PI * 0.09).abs() < 1e-15);
    assert!(disk.contains(DVec2::new(0.5, 0.79)) && !disk.contains(DVec2::new(0.5, 0.81)));
    assert!(disk.contains(DVec2::new(0.21, 0.5)) && !disk.contains(DVec2::new(0.19, 0.5)));
}

#[test]
fn invalid_loops_are_rejected() {
    assert!(TrimLoop::new(vec![]).is_err());
    assert!(Edge2::arc(DVec2::ZERO, -1.0, 0.0, 1.0).is_err());
    assert!(Edge2::segment(DVec2::new(f64::NAN, 0.0), DVec2::ZERO).is_err());
    let open = vec![
        Edge2::segment(DVec2::ZERO, DVec2::X).unwrap(),
        Edge2::segment(DVec2::X, DVec2::Y).unwrap(),
    ];
    assert!(TrimLoop::new(open).is_err());
}

#[test]
fn region_integration_matches_green_moments() {
    // ∫ 1 = area; ∫ x = ½∮ x² dy, ∫ y = −½∮ y² dx (Green), the boundary integrals done
    // by fine Gauss–Legendre on each edge's parametrization.
    let reg = region(
        &[1.0, 0.8, 0.9, 0.7, 1.0, 0.85],
        &[0.0, 1.0, -0.3, 0.5, 0.0, 0.9],
        0.07,
    );
    let gl = wavelux_quadrature::GaussLegendre::new(40).unwrap();
    let (mut mx, mut my) = (0.0, 0.0);
    for l in &reg.loops {
        for e in &l.edges {
            let h = 1e-7;
            mx += gl.integrate(0.0, 1.0, |s| {
                let p = e.point(s);
                let dy = (e.point(s + h).y - e.point(s - h).y) / (2.0 * h);
                0.5 * p.x * p.x * dy
            });
            my += gl.integrate(0.0, 1.0, |s| {
                let p = e.point(s);
                let dx = (e.point(s + h).x - e.point(s - h).x) / (2.0 * h);
                -0.5 * p.y * p.y * dx
            });
        }
    }
    let area = reg.integrate(12, |_| 1.0);
    assert!(
        (area - reg.area()).abs() <= 1e-12,
        "{area} vs {}",
        reg.area()
    );
    let ix = reg.integrate(12, |p| p.x);
    let iy = reg.integrate(12, |p| p.y);
    assert!((ix - mx).abs() <= 1e-8, "{ix} vs {mx}");
    assert!((iy - my).abs() <= 1e-8, "{iy} vs {my}");
}
