//! Shape properties: exact parallelogram merging (area preserved, deterministic),
//! polygon areas with arcs and holes against closed forms, Bézier area of a
//! bilinear (flat) patch, degenerate handling.

use glam::{DVec2, DVec3};
use proptest::prelude::*;
use wavelux_scene::shape::{TriangleMesh, is_degenerate};
use wavelux_scene::{BezierPatch, Loop, LoopEdge, PlaneFrame, PolygonShape, Shape};

fn v3() -> impl Strategy<Value = DVec3> {
    (-10.0..10.0f64, -10.0..10.0f64, -10.0..10.0f64).prop_map(|(x, y, z)| DVec3::new(x, y, z))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(128))]

    /// A parallelogram split along either diagonal merges back into one
    /// parallelogram of the same area and orientation.
    #[test]
    fn split_parallelogram_merges(o in v3(), u in v3(), v in v3(), diag in 0..2usize) {
        prop_assume!(!is_degenerate(u, v));
        let pos = vec![o, o + u, o + u + v, o + v];
        let tris = if diag == 0 { vec![[0, 1, 2], [0, 2, 3]] } else { vec![[0, 1, 3], [1, 2, 3]] };
        let b = TriangleMesh::build(pos, vec![], &tris, "t", "m").unwrap();
        prop_assert_eq!(b.dropped, 0);
        prop_assert_eq!(b.mesh.parallelograms.len(), 1);
        prop_assert!(b.mesh.triangles.is_empty());
        let area: f64 = b.mesh.elements().map(|e| e.area()).sum();
        prop_assert!((area - u.cross(v).length()).abs() <= 1e-9 * u.cross(v).length().max(1.0));
        let n = b.mesh.elements().next().unwrap().normal();
        prop_assert!(n.dot(u.cross(v)) > 0.0);
    }

    /// A general quad (not a parallelogram) stays two triangles, area preserved.
    #[test]
    fn skewed_quad_does_not_merge(o in v3(), u in v3(), v in v3(), d in 0.01..1.0f64) {
        prop_assume!(!is_degenerate(u, v));
        let pos = vec![o, o + u, o + (1.0 + d) * (u + v), o + v];
        let tris = vec![[0, 1, 2], [0, 2, 3]];
        let b = TriangleMesh::build(pos.clone(), vec![], &tris, "t", "m").unwrap();
        prop_assume!(b.dropped == 0);
        prop_assert!(b.mesh.parallelograms.is_empty());
        let tri = |a: DVec3, b: DVec3, c: DVec3| 0.5 * (b - a).cross(c - a).length();
        let want = tri(pos[0], pos[1], pos[2]) + tri(pos[0], pos[2], pos[3]);
        let got: f64 = b.mesh.elements().map(|e| e.area()).sum();
        prop_assert!((got - want).abs() <= 1e-9 * want.max(1.0));
    }

    /// Inconsistently oriented neighbours (one flipped) never merge.
    #[test]
    fn flipped_neighbour_does_not_merge(o in v3(), u in v3(), v in v3()) {
        prop_assume!(!is_degenerate(u, v));
        let pos = vec![o, o + u, o + u + v, o + v];
        let b = TriangleMesh::build(pos, vec![], &[[0, 1, 2], [0, 3, 2]], "t", "m").unwrap();
        prop_assert!(b.mesh.parallelograms.is_empty());
    }

    /// Disk of radius r with a square hole of side s = f·r at its centre (its far
    /// corner at √2 f r < r: the hole lies inside): π r² − s².
    #[test]
    fn polygon_with_arc_and_hole(r in 0.5..5.0f64, f in 0.01..0.7f64, cx in -3.0..3.0f64) {
        let c = DVec2::new(cx, 1.0);
        let s = f * r;
        let p = PolygonShape {
            frame: PlaneFrame { origin: DVec3::ZERO, u: DVec3::X, v: DVec3::Y },
            outer: Loop::circle(c, r),
            holes: vec![Loop::polygon(&[c, c + DVec2::new(s, 0.0), c + DVec2::splat(s), c + DVec2::new(0.0, s)])],
        };
        let want = std::f64::consts::PI * r * r - s * s;
        prop_assert!((p.area() - want).abs() < 1e-12 * want.max(1.0));
        Shape::Polygon(p).validate("t", "p").unwrap();
    }
}

#[test]
fn half_disk_and_clockwise_arcs() {
    // Half disk: segment from (−1,0) to (1,0), then ccw arc back through (0,1).
    let half = Loop {
        edges: vec![
            LoopEdge::Segment {
                start: DVec2::new(-1.0, 0.0),
            },
            LoopEdge::Arc {
                start: DVec2::new(1.0, 0.0),
                center: DVec2::ZERO,
                ccw: true,
            },
        ],
    };
    assert!((half.signed_area() - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    // The same boundary traversed clockwise (arc cw from (−1,0) over the top to (1,0)).
    let cw = Loop {
        edges: vec![
            LoopEdge::Arc {
                start: DVec2::new(-1.0, 0.0),
                center: DVec2::ZERO,
                ccw: false,
            },
            LoopEdge::Segment {
                start: DVec2::new(1.0, 0.0),
            },
        ],
    };
    assert!((cw.signed_area() + std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    // An arc whose end is off its circle is rejected.
    let bad = Shape::Polygon(PolygonShape {
        frame: PlaneFrame {
            origin: DVec3::ZERO,
            u: DVec3::X,
            v: DVec3::Y,
        },
        outer: Loop {
            edges: vec![
                LoopEdge::Segment {
                    start: DVec2::new(-1.0, 0.0),
                },
                LoopEdge::Arc {
                    start: DVec2::new(2.0, 0.0),
                    center: DVec2::ZERO,
                    ccw: true,
                },
            ],
        },
        holes: vec![],
    });
    assert!(bad.validate("f", "p").is_err());
}

#[test]
fn bezier_area_of_flat_and_curved_patches() {
    // Bicubic patch with control points on a regular grid of the plane: a 3 × 2
    // rectangle (the Bézier map is then affine), area exact.
    let mut control = Vec::new();
    for i in 0..4 {
        for j in 0..4 {
            control.push(DVec3::new(i as f64, 2.0 * j as f64 / 3.0, 0.0));
        }
    }
    let b = BezierPatch {
        degree_u: 3,
        degree_v: 3,
        control,
    };
    assert!((Shape::Bezier(b.clone()).area() - 6.0).abs() < 1e-9);
    // Quadratic-in-u cylinder-like patch: P(u, v) = (u, u², v) on [0,1]²; its area is
    // the arc length of y = x² on [0, 1]: (2√5 + asinh 2)/4.
    let b2 = BezierPatch {
        degree_u: 2,
        degree_v: 1,
        control: vec![
            DVec3::new(0.0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, 1.0),
            DVec3::new(0.5, 0.0, 0.0),
            DVec3::new(0.5, 0.0, 1.0),
            DVec3::new(1.0, 1.0, 0.0),
            DVec3::new(1.0, 1.0, 1.0),
        ],
    };
    let want = (2.0 * 5f64.sqrt() + 2f64.asinh()) / 4.0;
    assert!((Shape::Bezier(b2.clone()).area() - want).abs() < 1e-9 * want);
    let (p, du, dv) = b2.eval(0.5, 0.25);
    assert!((p - DVec3::new(0.5, 0.25, 0.25)).length() < 1e-15);
    assert!((du - DVec3::new(1.0, 1.0, 0.0)).length() < 1e-15);
    assert!((dv - DVec3::Z).length() < 1e-15);
    // Wrong control-point count is an error.
    let mut bad = b2;
    bad.control.pop();
    assert!(Shape::Bezier(bad).validate("f", "b").is_err());
}

#[test]
fn degenerate_and_non_finite_shapes_are_rejected() {
    let z = Shape::parallelogram(DVec3::ZERO, DVec3::X, DVec3::X * 2.0);
    assert!(matches!(
        z.validate("f", "p"),
        Err(wavelux_scene::SceneError::Degenerate { .. })
    ));
    let n = Shape::Triangle([DVec3::ZERO, DVec3::X, DVec3::new(f64::NAN, 1.0, 0.0)]);
    assert!(matches!(
        n.validate("f", "t"),
        Err(wavelux_scene::SceneError::NonFinite { .. })
    ));
}

#[test]
fn transforms_keep_areas_and_orientation() {
    let m = glam::DMat4::from_scale_rotation_translation(
        DVec3::splat(2.0),
        glam::DQuat::from_rotation_y(0.3),
        DVec3::new(1.0, 2.0, 3.0),
    );
    let p = Shape::Polygon(PolygonShape {
        frame: PlaneFrame {
            origin: DVec3::ZERO,
            u: DVec3::X,
            v: DVec3::Y,
        },
        outer: Loop::circle(DVec2::ZERO, 1.0),
        holes: vec![],
    });
    let t = p.transformed(&m).unwrap();
    assert!((t.area() - 4.0 * p.area()).abs() < 1e-12);
    // Non-similarity maps are refused for polygons.
    let shear = glam::DMat4::from_scale(DVec3::new(1.0, 2.0, 1.0));
    assert!(p.transformed(&shear).is_none());
}

fn prim_area(p: &wavelux_geometry::Primitive) -> f64 {
    use wavelux_geometry::Primitive as P;
    match p {
        P::Triangle(t) => t.area(),
        P::Parallelogram(q) => q.area(),
        P::Polygon(q) => q.area(),
        P::Trimmed(q) => q.area(),
        other => panic!("unexpected {other:?}"),
    }
}

#[test]
fn builtin_scenes_convert_to_geometry_with_the_same_areas() {
    for name in wavelux_scene::builtin::BUILTIN_NAMES {
        let s = wavelux_scene::builtin::builtin(name).unwrap();
        let prims = s.primitives("<test>").unwrap();
        for (i, surf) in s.surfaces.iter().enumerate() {
            let a: f64 = prims
                .iter()
                .filter(|(k, _)| *k == i)
                .map(|(_, p)| prim_area(p))
                .sum();
            let want = surf.shape.area();
            assert!(
                (a - want).abs() <= 1e-12 * want,
                "{name}/{}: {a} vs {want}",
                surf.name
            );
        }
    }
}

fn placement() -> wavelux_scene::Placement {
    wavelux_scene::Placement {
        origin: DVec3::new(1.0, 2.0, 3.0),
        axis: DVec3::new(0.0, 1.0, 1.0),
        reference: DVec3::X,
    }
}

#[test]
fn analytic_patches_have_closed_form_areas() {
    use std::f64::consts::{FRAC_PI_2, PI};
    use wavelux_scene::{AnalyticPatch, AnalyticSurface, Region};
    let sphere = AnalyticSurface::Sphere {
        placement: placement(),
        radius: 2.0,
        azimuth: (-PI, PI),
        latitude: (-FRAC_PI_2, FRAC_PI_2),
    };
    let full = Shape::Patch(AnalyticPatch {
        surface: sphere,
        trim: None,
    });
    full.validate("f", "s").unwrap();
    assert!((full.area() - 16.0 * PI).abs() < 1e-12 * 16.0 * PI);
    // Cylinder r = 0.5, h ∈ [0, 2], trimmed by a disk of radius 0.25 and a square hole
    // of side 0.1 in the equal-area square: area = 2π r h (π 0.25² − 0.01).
    let cyl = AnalyticSurface::Cylinder {
        placement: placement(),
        radius: 0.5,
        azimuth: (0.0, 2.0 * PI),
        height: (0.0, 2.0),
    };
    let c = DVec2::splat(0.5);
    let trimmed = Shape::Patch(AnalyticPatch {
        surface: cyl,
        trim: Some(Region {
            outer: Loop::circle(c, 0.25),
            holes: vec![Loop::polygon(&[
                c,
                c + DVec2::new(0.1, 0.0),
                c + DVec2::splat(0.1),
                c + DVec2::new(0.0, 0.1),
            ])],
        }),
    });
    trimmed.validate("f", "c").unwrap();
    let want = 2.0 * PI * 0.5 * 2.0 * (PI * 0.0625 - 0.01);
    assert!((trimmed.area() - want).abs() < 1e-12 * want);
    assert_eq!(trimmed.primitives("f", "c").unwrap().len(), 1);
    // A trim leaving the unit square is rejected.
    let bad = Shape::Patch(AnalyticPatch {
        surface: cyl,
        trim: Some(Region {
            outer: Loop::circle(DVec2::splat(0.9), 0.25),
            holes: vec![],
        }),
    });
    assert!(bad.validate("f", "c").is_err());
    // Torus: 4π² R r; cone with apex, φ ∈ [0, 1]: π a √(a² + b²).
    let torus = Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Torus {
            placement: placement(),
            major: 2.0,
            minor: 0.5,
            azimuth: (0.0, 2.0 * PI),
            tube: (0.0, 2.0 * PI),
        },
        trim: None,
    });
    assert!((torus.area() - 4.0 * PI * PI).abs() < 1e-9 * 4.0 * PI * PI);
    let cone = Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Cone {
            placement: placement(),
            radius: 1.0,
            height: 2.0,
            azimuth: (0.0, 2.0 * PI),
            generator: (0.0, 1.0),
        },
        trim: None,
    });
    assert!((cone.area() - PI * 5f64.sqrt()).abs() < 1e-12 * PI * 5f64.sqrt());
    // Similarity transforms scale areas by s².
    let m = glam::DMat4::from_scale_rotation_translation(
        DVec3::splat(3.0),
        glam::DQuat::from_rotation_x(0.4),
        DVec3::ONE,
    );
    let t = trimmed.transformed(&m).unwrap();
    assert!((t.area() - 9.0 * want).abs() < 1e-11 * want);
    // Invalid parameters are typed errors.
    let bad_torus = Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Torus {
            placement: placement(),
            major: 1.0,
            minor: 2.0,
            azimuth: (0.0, 1.0),
            tube: (0.0, 1.0),
        },
        trim: None,
    });
    assert!(bad_torus.validate("f", "t").is_err());
}

#[test]
fn low_degree_bezier_elevates_exactly() {
    // A biquadratic patch and its bicubic elevation agree pointwise.
    let mut control = Vec::new();
    for i in 0..3 {
        for j in 0..3 {
            control.push(DVec3::new(i as f64, j as f64, ((i * j) as f64).sin()));
        }
    }
    let b = BezierPatch {
        degree_u: 2,
        degree_v: 2,
        control,
    };
    let cubic = BezierPatch {
        degree_u: 3,
        degree_v: 3,
        control: b.bicubic().iter().flatten().copied().collect(),
    };
    for (u, v) in [(0.1, 0.2), (0.5, 0.5), (0.9, 0.3), (0.0, 1.0)] {
        assert!((b.eval(u, v).0 - cubic.eval(u, v).0).length() < 1e-14);
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(32))]

    /// A grid of parallelograms (an affine image of a rectangular grid), each split
    /// along either diagonal, merges back completely: one parallelogram per cell.
    #[test]
    fn split_grid_merges_completely(
        nx in 1..12usize, nz in 1..12usize, u in v3(), v in v3(), flips in proptest::collection::vec(any::<bool>(), 144)
    ) {
        prop_assume!(!is_degenerate(u, v));
        // Cells much longer in one direction than the other stress the longest-edge rule.
        let (u, v) = (u, v * 0.3);
        let mut pos = Vec::new();
        for k in 0..=nz {
            for i in 0..=nx {
                pos.push(u * i as f64 + v * k as f64);
            }
        }
        let w = (nx + 1) as u32;
        let mut tris = Vec::new();
        for k in 0..nz as u32 {
            for i in 0..nx as u32 {
                let a = k * w + i;
                let (b, c, d) = (a + 1, a + 1 + w, a + w);
                if flips[(k as usize * nx + i as usize) % 144] {
                    tris.extend([[a, b, c], [a, c, d]]);
                } else {
                    tris.extend([[a, b, d], [b, c, d]]);
                }
            }
        }
        let m = TriangleMesh::build(pos, vec![], &tris, "t", "m").unwrap().mesh;
        let area: f64 = m.elements().map(|e| e.area()).sum();
        let want = (nx * nz) as f64 * u.cross(v).length();
        prop_assert!((area - want).abs() <= 1e-9 * want.max(1.0));
        prop_assert!(m.parallelograms.len() * 2 + m.triangles.len() == 2 * nx * nz);
        // Longest-edge-first pairs every cell whose split diagonal is the longer one.
        let long_diag = (u + v).length() > (u - v).length();
        let all_long = (0..nx * nz).all(|c| flips[c % 144] == long_diag);
        if all_long {
            prop_assert_eq!(m.parallelograms.len(), nx * nz);
        }
    }
}

/// A polygon in the plane z = 0 with an outer square `[0, 2]²` and these holes.
fn square_with(holes: Vec<Loop>) -> Shape {
    Shape::Polygon(PolygonShape {
        frame: PlaneFrame {
            origin: DVec3::ZERO,
            u: DVec3::X,
            v: DVec3::Y,
        },
        outer: Loop::polygon(&[
            DVec2::new(0.0, 0.0),
            DVec2::new(2.0, 0.0),
            DVec2::new(2.0, 2.0),
            DVec2::new(0.0, 2.0),
        ]),
        holes,
    })
}

fn square(x: f64, y: f64, side: f64) -> Loop {
    Loop::polygon(&[
        DVec2::new(x, y),
        DVec2::new(x + side, y),
        DVec2::new(x + side, y + side),
        DVec2::new(x, y + side),
    ])
}

fn malformed(shape: &Shape) -> String {
    match shape.validate("f.toml", "surface \"p\"") {
        Err(wavelux_scene::SceneError::Malformed {
            file,
            element,
            what,
        }) => {
            assert_eq!(
                (file.as_str(), element.as_str()),
                ("f.toml", "surface \"p\"")
            );
            what
        }
        other => panic!("expected a malformed-region error, got {other:?}"),
    }
}

#[test]
fn holes_must_lie_inside_and_apart() {
    // Valid: two disjoint holes, a hole touching the outer loop along an edge, a
    // circular hole; areas are then exact.
    let ok = square_with(vec![square(0.2, 0.2, 0.5), square(1.0, 1.0, 0.5)]);
    ok.validate("f", "p").unwrap();
    assert!((ok.area() - 3.5).abs() < 1e-12);
    let touching = square_with(vec![square(0.0, 0.5, 0.5)]);
    touching.validate("f", "p").unwrap();
    assert!((touching.area() - 3.75).abs() < 1e-12);
    square_with(vec![Loop::circle(DVec2::new(1.0, 1.0), 0.5)])
        .validate("f", "p")
        .unwrap();
    // A hole outside the outer loop (the area would read 4 − 1 = 3, not 4).
    let what = malformed(&square_with(vec![square(5.0, 5.0, 1.0)]));
    assert!(
        what.contains("hole 0 is not inside the outer loop"),
        "{what}"
    );
    // A hole crossing the outer loop.
    let what = malformed(&square_with(vec![square(1.5, 1.5, 1.0)]));
    assert!(what.contains("hole 0 is not inside"), "{what}");
    // Overlapping and nested holes.
    let what = malformed(&square_with(vec![
        square(0.2, 0.2, 0.5),
        square(0.5, 0.5, 0.5),
    ]));
    assert!(what.contains("holes 0 and 1 overlap"), "{what}");
    let what = malformed(&square_with(vec![
        square(0.2, 0.2, 1.0),
        square(0.5, 0.5, 0.2),
    ]));
    assert!(what.contains("holes 0 and 1 overlap"), "{what}");
    // A self-crossing (bow-tie) hole, and a self-crossing outer loop.
    let bowtie = Loop::polygon(&[
        DVec2::new(0.5, 0.5),
        DVec2::new(1.5, 1.5),
        DVec2::new(1.5, 0.5),
        DVec2::new(0.5, 1.5),
    ]);
    let what = malformed(&square_with(vec![bowtie.clone()]));
    assert!(what.contains("hole 0 crosses or overlaps itself"), "{what}");
    let what = malformed(&Shape::Polygon(PolygonShape {
        frame: PlaneFrame {
            origin: DVec3::ZERO,
            u: DVec3::X,
            v: DVec3::Y,
        },
        outer: bowtie,
        holes: vec![],
    }));
    assert!(
        what.contains("outer loop crosses or overlaps itself"),
        "{what}"
    );
    // Two circular holes overlapping.
    let what = malformed(&square_with(vec![
        Loop::circle(DVec2::new(0.8, 1.0), 0.4),
        Loop::circle(DVec2::new(1.2, 1.0), 0.4),
    ]));
    assert!(what.contains("holes 0 and 1 overlap"), "{what}");
}

#[test]
fn surfaces_of_zero_or_infinite_area_are_errors() {
    use wavelux_scene::SceneError;
    let big = Shape::parallelogram(DVec3::ZERO, DVec3::X * 1e308, DVec3::Y * 1e308);
    assert!(matches!(
        big.validate("f", "e"),
        Err(SceneError::NonFinite { ref what, .. }) if what == "area"
    ));
    let tri = Shape::Triangle([DVec3::ZERO, DVec3::X * 1e200, DVec3::Y * 1e200]);
    assert!(matches!(
        tri.validate("f", "e"),
        Err(SceneError::NonFinite { .. })
    ));
    let hole_is_all = square_with(vec![square(0.0, 0.0, 2.0)]);
    assert!(matches!(
        hole_is_all.validate("f", "e"),
        Err(SceneError::Degenerate { .. })
    ));
    // A mesh triangle whose area overflows is an error naming the triangle.
    let huge = vec![DVec3::ZERO, DVec3::X * 1e200, DVec3::Y * 1e200];
    match TriangleMesh::build(huge, vec![], &[[0, 1, 2]], "f", "e") {
        Err(SceneError::NonFinite { what, .. }) => assert_eq!(what, "area of triangle 0"),
        other => panic!("expected a non-finite area, got {other:?}"),
    }
}
