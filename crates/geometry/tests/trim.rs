//! Slab-decomposition trimming test vs brute-force winding numbers.

use glam::DVec2;
use proptest::prelude::*;
use std::f64::consts::{PI, TAU};
use wavelux_geometry::{Edge2, GeometryError, RegionFault, TrimLoop, TrimRegion};

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

fn square(x: f64, y: f64, s: f64) -> TrimLoop {
    TrimLoop::rect(DVec2::new(x, y), DVec2::new(x + s, y + s)).unwrap()
}

fn fault(loops: Vec<TrimLoop>) -> RegionFault {
    match TrimRegion::new(loops) {
        Err(GeometryError::Region(f)) => f,
        other => panic!("expected an improper-region error, got {other:?}"),
    }
}

#[test]
fn improper_regions_name_the_loop_at_fault() {
    let outer = || square(0.0, 0.0, 1.0);
    // A hole entirely outside (the area used to read 1 − 0.25 = 0.75).
    let far = square(2.0, 0.0, 0.5).reversed();
    assert_eq!(
        fault(vec![outer(), far]),
        RegionFault::HoleOutside { index: 1 }
    );
    // A triangular hole poking out through the right edge between two slab cuts: at
    // every slab's mid-height its pieces lie inside the square, so the cells' winding
    // numbers alone (0 or 1 there) do not see it; the crossing check does.
    let poke = TrimLoop::polygon(&[
        DVec2::new(0.5, 0.4),
        DVec2::new(0.5, 0.6),
        DVec2::new(1.2, 0.5),
    ])
    .unwrap();
    let poke = if poke.signed_area() > 0.0 {
        poke.reversed()
    } else {
        poke
    };
    assert_eq!(
        fault(vec![outer(), poke.clone()]),
        RegionFault::HoleOutside { index: 1 }
    );
    let e = TrimRegion::new(vec![outer(), poke])
        .unwrap_err()
        .to_string();
    assert!(e.contains("trim loop 1") && e.contains("not inside"), "{e}");
    // A circular hole crossing the square's top edge.
    assert_eq!(
        fault(vec![
            outer(),
            TrimLoop::circle(DVec2::new(0.5, 0.95), 0.1)
                .unwrap()
                .reversed()
        ]),
        RegionFault::HoleOutside { index: 1 }
    );
    // Overlapping, and nested, holes.
    assert_eq!(
        fault(vec![
            outer(),
            square(0.1, 0.1, 0.4).reversed(),
            square(0.3, 0.3, 0.4).reversed()
        ]),
        RegionFault::Overlap { a: 1, b: 2 }
    );
    assert_eq!(
        fault(vec![
            outer(),
            square(0.1, 0.1, 0.8).reversed(),
            square(0.3, 0.3, 0.2).reversed()
        ]),
        RegionFault::Overlap { a: 1, b: 2 }
    );
    // Two overlapping outer loops (winding 2 where they overlap).
    assert_eq!(
        fault(vec![outer(), square(0.5, 0.5, 1.0)]),
        RegionFault::Overlap { a: 0, b: 1 }
    );
    // A bow-tie (self-crossing) hole.
    let bowtie = TrimLoop::polygon(&[
        DVec2::new(0.2, 0.2),
        DVec2::new(0.8, 0.8),
        DVec2::new(0.8, 0.2),
        DVec2::new(0.2, 0.8),
    ])
    .unwrap();
    assert_eq!(
        fault(vec![outer(), bowtie]),
        RegionFault::SelfCrossing { index: 1 }
    );
    // A lone clockwise loop is a hole in nothing.
    assert_eq!(
        fault(vec![outer().reversed()]),
        RegionFault::HoleOutside { index: 0 }
    );
}

#[test]
fn touching_loops_and_islands_are_proper() {
    let outer = || square(0.0, 0.0, 1.0);
    // A hole sharing part of the outer loop's edge, two holes sharing an edge, a
    // circular hole tangent to the outer loop, an island inside a hole: all exact areas.
    let cases: Vec<(Vec<TrimLoop>, f64)> = vec![
        (vec![outer(), square(0.0, 0.25, 0.5).reversed()], 0.75),
        (
            vec![
                outer(),
                square(0.1, 0.1, 0.3).reversed(),
                square(0.4, 0.1, 0.3).reversed(),
            ],
            1.0 - 0.18,
        ),
        (
            vec![
                outer(),
                TrimLoop::circle(DVec2::new(0.5, 0.75), 0.25)
                    .unwrap()
                    .reversed(),
            ],
            1.0 - PI / 16.0,
        ),
        (
            vec![
                outer(),
                square(0.1, 0.1, 0.8).reversed(),
                square(0.3, 0.3, 0.2),
            ],
            1.0 - 0.64 + 0.04,
        ),
    ];
    for (k, (loops, area)) in cases.into_iter().enumerate() {
        let r = TrimRegion::new(loops).unwrap_or_else(|e| panic!("case {k}: {e}"));
        assert!(
            (r.area() - area).abs() < 1e-12,
            "case {k}: {} vs {area}",
            r.area()
        );
        assert_eq!(r.winding_bounds(1e-9), (0, 1), "case {k}");
    }
}

/// A star-shaped polygon around `c` (simple: strictly increasing angles), clockwise if
/// `hole`.
fn star(c: DVec2, radii: &[f64], phase: f64, hole: bool) -> TrimLoop {
    let n = radii.len();
    let pts: Vec<DVec2> = (0..n)
        .map(|k| c + radii[k] * DVec2::from_angle(phase + TAU * k as f64 / n as f64))
        .collect();
    let l = TrimLoop::polygon(&pts).unwrap();
    if hole { l.reversed() } else { l }
}

/// Corners of a polygonal loop.
fn corners(l: &TrimLoop) -> Vec<DVec2> {
    l.edges.iter().map(Edge2::start).collect()
}

/// Distance from `p` to the segment `ab`.
fn point_segment(p: DVec2, a: DVec2, b: DVec2) -> f64 {
    let t = ((p - a).dot(b - a) / (b - a).length_squared()).clamp(0.0, 1.0);
    (a + t * (b - a) - p).length()
}

/// True if the closed segments `ab` and `cd` intersect (orientation signs).
fn segments_meet(a: DVec2, b: DVec2, c: DVec2, d: DVec2) -> bool {
    let o = |p: DVec2, q: DVec2, r: DVec2| (q - p).perp_dot(r - p);
    o(a, b, c) * o(a, b, d) <= 0.0 && o(c, d, a) * o(c, d, b) <= 0.0
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    /// A random star hole placed anywhere near a random star outer loop is accepted
    /// exactly when it lies inside (no edge pair meets, one corner inside by the
    /// brute-force winding number), with area `|outer| − |hole|`; otherwise the error
    /// names it. Configurations within `1e-6` of touching are skipped (the tolerance
    /// decides those).
    #[test]
    fn hole_is_accepted_exactly_when_inside(
        outer_r in prop::collection::vec(0.4f64..1.0, 3..9),
        hole_r in prop::collection::vec(0.05f64..0.4, 3..7),
        c in (-1.2f64..1.2, -1.2f64..1.2),
        phases in (0.0f64..TAU, 0.0f64..TAU),
    ) {
        let outer = star(DVec2::ZERO, &outer_r, phases.0, false);
        let hole = star(DVec2::new(c.0, c.1), &hole_r, phases.1, true);
        let (po, ph) = (corners(&outer), corners(&hole));
        let mut gap = f64::INFINITY;
        let mut meet = false;
        for i in 0..po.len() {
            let (a, b) = (po[i], po[(i + 1) % po.len()]);
            for j in 0..ph.len() {
                let (p, q) = (ph[j], ph[(j + 1) % ph.len()]);
                meet |= segments_meet(a, b, p, q);
                gap = gap
                    .min(point_segment(a, p, q))
                    .min(point_segment(p, a, b));
            }
        }
        prop_assume!(gap > 1e-6);
        let inside = !meet && outer.winding_brute(ph[0]) == 1;
        match TrimRegion::new(vec![outer.clone(), hole.clone()]) {
            Ok(r) => {
                prop_assert!(inside, "accepted a hole that is not inside");
                let want = outer.signed_area() + hole.signed_area();
                prop_assert!((r.area() - want).abs() < 1e-12);
            }
            Err(e) => {
                prop_assert!(!inside, "rejected a hole inside: {}", e);
                prop_assert_eq!(e, GeometryError::Region(RegionFault::HoleOutside { index: 1 }));
            }
        }
    }
}
