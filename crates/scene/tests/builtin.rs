//! Built-in scenes: areas against the defining dimensions, orientation of every
//! face, materials, Ziegler's table averages, and validation.

use glam::DVec3;
use wavelux_scene::builtin::{self, BoxVariant, Reflectivity};
use wavelux_scene::{MeshElement, Scene, Shape, Sidedness};

/// `(centroid, area-weighted normal)` of a planar-faced shape.
fn centroid_normal(shape: &Shape) -> (DVec3, DVec3) {
    match shape {
        Shape::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => (*origin + 0.5 * (*edge_u + *edge_v), edge_u.cross(*edge_v)),
        Shape::Mesh(m) => {
            let mut c = DVec3::ZERO;
            let mut n = DVec3::ZERO;
            let mut a = 0.0;
            for e in m.elements() {
                let (ec, en) = match e {
                    MeshElement::Triangle([p, q, r]) => {
                        ((p + q + r) / 3.0, 0.5 * (q - p).cross(r - p))
                    }
                    MeshElement::Parallelogram {
                        origin,
                        edge_u,
                        edge_v,
                    } => (origin + 0.5 * (edge_u + edge_v), edge_u.cross(edge_v)),
                };
                c += ec * en.length();
                a += en.length();
                n += en;
            }
            (c / a, n)
        }
        Shape::Polygon(p) => {
            let mut c = DVec3::ZERO;
            let pts: Vec<_> = p
                .outer
                .edges
                .iter()
                .map(|e| p.frame.point(e.start()))
                .collect();
            for q in &pts {
                c += *q;
            }
            (c / pts.len() as f64, p.frame.normal() * p.area())
        }
        other => panic!("unexpected shape {other:?}"),
    }
}

fn assert_valid(s: &Scene) {
    s.validate("<test>").unwrap();
    assert!(s.warnings.is_empty());
}

#[test]
fn cornell_box_geometry_and_materials() {
    let s = builtin::cornell_box();
    assert_valid(&s);
    let names: Vec<_> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(
        names,
        [
            "floor",
            "ceiling",
            "back_wall",
            "left_wall",
            "right_wall",
            "short_block",
            "tall_block",
            "light"
        ]
    );
    let light_area = 0.130 * 0.105;
    let area = |n: &str| s.surface(n).unwrap().shape.area();
    assert!((area("light") - light_area).abs() < 1e-15);
    assert!((area("ceiling") - (0.556 * 0.5592 - light_area)).abs() < 1e-14);
    // Right wall is an exact 548.8 × 559.2 rectangle; floor is a planar trapezoid.
    assert!((area("right_wall") - 0.5488 * 0.5592).abs() < 1e-14);
    assert!((area("floor") - 0.5 * (0.5528 + 0.5496) * 0.5592).abs() < 1e-14);
    // Block side faces are exact rectangles and merge into parallelograms.
    let Shape::Mesh(tall) = &s.surface("tall_block").unwrap().shape else {
        panic!()
    };
    assert_eq!(tall.parallelograms.len(), 4);
    assert_eq!(tall.triangle_count(), 10);
    // Walls face into the box, block faces out of their block.
    let centre = DVec3::new(0.278, 0.2744, 0.2796);
    for w in [
        "floor",
        "ceiling",
        "back_wall",
        "left_wall",
        "right_wall",
        "light",
    ] {
        let (c, n) = centroid_normal(&s.surface(w).unwrap().shape);
        assert!(n.dot(centre - c) > 0.0, "{w} faces outwards");
    }
    for b in ["short_block", "tall_block"] {
        let Shape::Mesh(m) = &s.surface(b).unwrap().shape else {
            panic!()
        };
        let bc = m.positions.iter().fold(DVec3::ZERO, |a, p| a + *p) / m.positions.len() as f64;
        for e in m.elements() {
            let (c, n) = centroid_normal(&Shape::Mesh(wavelux_scene::TriangleMesh {
                positions: match e {
                    MeshElement::Triangle(t) => t.to_vec(),
                    MeshElement::Parallelogram {
                        origin,
                        edge_u,
                        edge_v,
                    } => {
                        vec![
                            origin,
                            origin + edge_u,
                            origin + edge_u + edge_v,
                            origin + edge_v,
                        ]
                    }
                },
                uv_sets: vec![],
                triangles: match e {
                    MeshElement::Triangle(_) => vec![[0, 1, 2]],
                    _ => vec![[0, 1, 2], [0, 2, 3]],
                },
                parallelograms: vec![],
            }));
            assert!(n.dot(c - bc) > 0.0, "{b} face points inwards");
        }
    }
    // Only the light emits; power = area × π × radiance.
    let p = s.emitted_power();
    for c in 0..3 {
        let want = light_area * std::f64::consts::PI * builtin::CORNELL_LIGHT_RADIANCE.0[c];
        assert!((p[c] - want).abs() < 1e-12 * want);
    }
    let red = &s.materials[s.surface("left_wall").unwrap().material];
    assert_eq!(red.reflectance, builtin::CORNELL_RED);
    assert_eq!(s.cameras.len(), 1);
    let cam = &s.cameras[0];
    assert_eq!(cam.forward, DVec3::Z);
    // The camera sees red on its left: right vector = forward × up = −x, red wall at +x.
    assert!(cam.right().x < 0.0);
}

#[test]
fn ziegler_unoccluded_and_occluded() {
    let u = builtin::unoccluded();
    assert_valid(&u);
    assert_eq!(u.surfaces.len(), 2);
    let s1 = &u.surface("S1").unwrap().shape;
    assert!((s1.area() - builtin::UNOCCLUDED_EMITTER_SIDE.powi(2)).abs() < 1e-15);
    let (c, n) = centroid_normal(s1);
    assert!((c - DVec3::new(0.5, 0.5, 0.1)).length() < 1e-15);
    assert!(n.normalize().dot(DVec3::NEG_Z) > 1.0 - 1e-15);
    // Rotated: no edge of the emitter is parallel to the receiver's edges.
    let Shape::Parallelogram { edge_u, .. } = s1 else {
        panic!()
    };
    assert!(edge_u.x.abs() > 1e-3 && edge_u.y.abs() > 1e-3);
    assert_eq!(
        u.materials[u.surface("S1").unwrap().material].reflectance.0,
        [0.0; 3]
    );
    assert_eq!(
        u.materials[u.surface("S0").unwrap().material].reflectance.0,
        [0.4; 3]
    );

    let o = builtin::occluded();
    assert_valid(&o);
    // S1 and its emitting part tile the unit square.
    let a = o.surface("S1").unwrap().shape.area() + o.surface("S1.emitter").unwrap().shape.area();
    assert!((a - 1.0).abs() < 1e-15);
    let p = o.emitted_power();
    assert!((p[0] - 100.0 * 0.25).abs() < 1e-12);
    let (c2, n2) = centroid_normal(&o.surface("S2").unwrap().shape);
    assert!((c2 - DVec3::splat(0.5)).length() < 1e-15 && n2.z > 0.0);
}

#[test]
fn ziegler_boxes_follow_the_table() {
    for cube in [false, true] {
        for r in [Reflectivity::High, Reflectivity::Low] {
            for v in [BoxVariant::A, BoxVariant::B] {
                let s = builtin::ziegler_box(cube, r, v);
                assert_valid(&s);
                assert_eq!(s.surfaces.len(), if cube { 13 } else { 7 });
                let area = s.total_area();
                let want = 54.0 + if cube { 6.0 } else { 0.0 };
                assert!((area - want).abs() < 1e-12);
                for (i, surf) in s.surfaces.iter().enumerate() {
                    let rho = s.materials[surf.material].reflectance.0[0];
                    let idx: usize = surf.name[1..].split('.').next().unwrap().parse().unwrap();
                    assert_eq!(rho, builtin::ziegler_box_reflectance(idx, r, v), "{i}");
                    // Outer faces point into the box, cube faces out of the cube.
                    let (c, n) = centroid_normal(&surf.shape);
                    let to_centre = DVec3::splat(1.5) - c;
                    if idx < 6 {
                        assert!(n.dot(to_centre) > 0.0);
                    } else {
                        assert!(n.dot(to_centre) < 0.0);
                    }
                }
            }
        }
    }
    // Ziegler quotes ρ_avg = 0.52 (high) and 0.35 (low): the unweighted mean over the
    // twelve table entries, averaged over the (a)/(b) alternatives.
    let avg = |r| {
        (0..12)
            .map(|i| {
                0.5 * (builtin::ziegler_box_reflectance(i, r, BoxVariant::A)
                    + builtin::ziegler_box_reflectance(i, r, BoxVariant::B))
            })
            .sum::<f64>()
            / 12.0
    };
    assert_eq!((avg(Reflectivity::High) * 100.0).round(), 52.0);
    assert_eq!((avg(Reflectivity::Low) * 100.0).round(), 35.0);
}

#[test]
fn white_furnace_is_closed_and_inward() {
    let s = builtin::white_furnace(3.0, 0.25).unwrap();
    assert_valid(&s);
    assert_eq!(s.surfaces.len(), 6);
    assert!((s.total_area() - 6.0).abs() < 1e-15);
    let mut nsum = DVec3::ZERO;
    for f in &s.surfaces {
        let (c, n) = centroid_normal(&f.shape);
        assert!((n.length() - 1.0).abs() < 1e-15);
        assert!((DVec3::splat(0.5) - c).normalize().dot(n) > 1.0 - 1e-15);
        assert_eq!(f.sides, Sidedness::OneSided);
        nsum += n;
    }
    // Closed surface: the area-weighted normals cancel.
    assert!(nsum.length() < 1e-15);
    assert!(builtin::white_furnace(1.0, 1.0).is_err());
    assert!(builtin::white_furnace(-1.0, 0.5).is_err());
    assert!(builtin::white_furnace(f64::NAN, 0.5).is_err());
}

#[test]
fn builtin_by_name() {
    for n in builtin::BUILTIN_NAMES {
        let s = builtin::builtin(n).unwrap();
        assert_eq!(s.name, *n);
        assert_valid(&s);
    }
    assert!(builtin::builtin("nope").is_none());
    assert!(builtin::builtin("ziegler-box-occluded-high-c").is_none());
}
