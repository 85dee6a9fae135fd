//! Mesh grouping: triangles written by an exporter come back as the surfaces they tile
//! (a ring-tessellated disk as one 128-gon, the Cornell floor with its two holes),
//! with areas against closed forms, at scales 1e-4..1e4, through real GLB files; and
//! T-junctions, split vertices, non-manifold edges and overlaps never give a wrong
//! polygon.

use std::f64::consts::TAU;

use glam::{DMat4, DVec3};
use proptest::prelude::*;
use wavelux_scene::{
    AnalyticSurface, GltfOptions, LoopEdge, MeshGrouping, Rgb, Scene, Shape, Sidedness, Surface,
    TessellateOptions, TriangleMesh, WarningKind, fixtures, group_mesh, load_gltf_slice,
    tessellated, to_glb,
};

fn mesh(positions: Vec<DVec3>, tris: &[[u32; 3]]) -> TriangleMesh {
    TriangleMesh::build(positions, Vec::new(), tris, "t", "m")
        .unwrap()
        .mesh
}

fn roundtrip(scene: &Scene, grouping: MeshGrouping) -> Scene {
    let glb = to_glb(scene, "t.glb").unwrap();
    load_gltf_slice(
        &glb,
        "t.glb",
        None,
        &GltfOptions {
            grouping,
            ..GltfOptions::default()
        },
    )
    .unwrap()
}

fn polygon(s: &Shape) -> &wavelux_scene::PolygonShape {
    match s {
        Shape::Polygon(p) => p,
        other => panic!("expected a polygon, got {other:?}"),
    }
}

/// Area of a regular n-gon of circumradius r.
fn ngon_area(n: u32, r: f64) -> f64 {
    0.5 * f64::from(n) * r * r * (TAU / f64::from(n)).sin()
}

/// The disk of a polygon whose outer loop is one full circle: (centre, radius).
fn disk_of(s: &Shape) -> Option<(glam::DVec2, f64)> {
    let Shape::Polygon(p) = s else { return None };
    match (&p.outer.edges[..], p.holes.is_empty()) {
        (
            [
                LoopEdge::Arc {
                    start,
                    center,
                    ccw: true,
                },
            ],
            true,
        ) => Some((*center, (*start - *center).length())),
        _ => None,
    }
}

#[test]
fn ring_disks_become_one_disk_each() {
    let scene = fixtures::coaxial_disks(1.0, 1.0, 128, 8);
    let s = roundtrip(&scene, MeshGrouping::Surfaces);
    assert_eq!(s.surfaces.len(), 2);
    for (surf, normal) in s.surfaces.iter().zip([DVec3::Z, -DVec3::Z]) {
        let (_, r) = disk_of(&surf.shape)
            .unwrap_or_else(|| panic!("{}: not a disk: {:?}", surf.name, surf.shape));
        assert!((polygon(&surf.shape).frame.normal() - normal).length() < 1e-6);
        // f32 positions: radius within 1e-6; the area is the disk's, not the 128-gon's.
        assert!((r - 1.0).abs() < 1e-6, "{r}");
        let exact = std::f64::consts::PI;
        assert!((surf.shape.area() - exact).abs() < 2e-6 * exact);
        assert!(surf.shape.area() > ngon_area(128, 1.0) * (1.0 + 1e-4));
    }
    // The 128 degenerate centre triangles of each grid are dropped with a warning.
    assert_eq!(
        s.warnings.iter().map(|w| &w.kind).collect::<Vec<_>>(),
        [&WarningKind::DegenerateTrianglesDropped { count: 128 }; 2]
    );
    // The old behaviour stays available for comparison.
    let t = roundtrip(&scene, MeshGrouping::Triangles);
    assert_eq!(t.surfaces.len(), 2);
    for surf in &t.surfaces {
        let Shape::Mesh(m) = &surf.shape else {
            panic!("expected triangles")
        };
        assert_eq!(m.triangle_count(), 1920);
        assert!((surf.shape.area() - ngon_area(128, 1.0)).abs() < 1e-6);
    }
}

#[test]
fn cornell_faces_group_into_floor_and_ceiling_with_holes() {
    let faces = fixtures::cornell_faces();
    let tess = tessellated(&faces, &TessellateOptions::default()).unwrap();
    let s = roundtrip(&tess, MeshGrouping::Surfaces);
    let names: Vec<&str> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    let want: Vec<&str> = faces.surfaces.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, want);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    for (name, holes) in [("floor", 2), ("ceiling", 1)] {
        let got = s.surface(name).unwrap();
        let p = polygon(&got.shape);
        assert_eq!(p.holes.len(), holes, "{name}");
        assert_eq!(p.outer.edges.len(), 4, "{name}");
        assert!(p.holes.iter().all(|h| h.edges.len() == 4), "{name}");
        let exact = faces.surface(name).unwrap().shape.area();
        assert!(
            (got.shape.area() - exact).abs() < 1e-6 * exact,
            "{name}: {} vs {exact}",
            got.shape.area()
        );
        // Orientation: the front of both faces the inside of the box.
        let n = p.frame.normal();
        let want = if name == "floor" { DVec3::Y } else { -DVec3::Y };
        assert!((n - want).length() < 1e-6, "{name}: {n}");
    }
    assert!((s.total_area() - faces.total_area()).abs() < 1e-6 * faces.total_area());
}

#[test]
fn a_closed_sphere_mesh_becomes_the_sphere_with_its_inside_as_front() {
    let scene = fixtures::closed_sphere(1.0, 72, 36, 0.5, 1.0).unwrap();
    let s = roundtrip(&scene, MeshGrouping::Surfaces);
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    assert_eq!(s.surfaces.len(), 1);
    let surf = &s.surfaces[0];
    assert_eq!(surf.name, "sphere");
    let Shape::Patch(p) = &surf.shape else {
        panic!("expected the sphere, got {:?}", surf.shape)
    };
    let AnalyticSurface::Sphere {
        placement, radius, ..
    } = p.surface
    else {
        panic!("expected a sphere, got {:?}", p.surface)
    };
    // f32 positions: centre and radius within 1e-6.
    assert!((radius - 1.0).abs() < 1e-6, "{radius}");
    assert!(placement.origin.length() < 1e-6, "{}", placement.origin);
    assert!((surf.shape.area() - 2.0 * TAU).abs() < 1e-5);
    // The mesh faced inwards: its material is the sphere's back (inside), the front
    // (outside) is black, as a one-sided mesh's back was.
    let furnace = s.material_id("furnace").unwrap();
    assert_eq!(surf.sides, Sidedness::TwoSided { back: furnace });
    let front = &s.materials[surf.material];
    assert_eq!(front.reflectance, Rgb::BLACK);
    assert_eq!(front.emission, Rgb::BLACK);
    // The old behaviour stays available: the facets.
    let t = roundtrip(&scene, MeshGrouping::Triangles);
    let Shape::Mesh(m) = &t.surfaces[0].shape else {
        panic!("expected the facets")
    };
    assert_eq!(m.triangle_count(), 5040);
}

/// A UV sphere's mesh scaled, rotated and moved.
fn sphere_mesh(lon: u32, lat: u32, inward: bool, scale: f64, offset: DVec3) -> TriangleMesh {
    let (p, t) = fixtures::uv_sphere(1.0, lon, lat, inward);
    let m = DMat4::from_translation(offset)
        * DMat4::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.4)
        * DMat4::from_scale(DVec3::splat(scale));
    mesh(p.into_iter().map(|x| m.transform_point3(x)).collect(), &t)
}

fn fitted_sphere(g: &wavelux_scene::Grouped) -> Option<(DVec3, f64, bool)> {
    let [part] = &g.parts[..] else { return None };
    let Shape::Patch(p) = &part.shape else {
        return None;
    };
    let AnalyticSurface::Sphere {
        placement, radius, ..
    } = p.surface
    else {
        return None;
    };
    Some((placement.origin, radius, part.reversed))
}

#[test]
fn sphere_fits_are_scale_invariant_from_1e_minus_4_to_1e4() {
    for e in -4..=4 {
        let s = 10f64.powi(e);
        let offset = DVec3::new(3.0, -1.0, 2.0) * s;
        for (lon, lat) in [(72, 36), (24, 12)] {
            for inward in [false, true] {
                let g = group_mesh(&sphere_mesh(lon, lat, inward, s, offset), "t", "m").unwrap();
                assert!(g.warnings.is_empty(), "scale {s}: {:?}", g.warnings);
                let (c, r, reversed) = fitted_sphere(&g)
                    .unwrap_or_else(|| panic!("scale {s}, {lon}×{lat}: not a sphere"));
                assert!((r - s).abs() < 1e-9 * s, "scale {s}: radius {r}");
                assert!((c - offset).length() < 1e-9 * s, "scale {s}: centre {c}");
                assert_eq!(reversed, inward);
                assert_eq!(g.grouped_triangles, 2 * lon as usize * (lat as usize - 1));
            }
        }
    }
}

#[test]
fn coarse_open_or_squashed_spheres_stay_facets() {
    // Too coarse to be meant as a sphere (facets 22° across): an 8 × 4 UV sphere.
    let g = group_mesh(&sphere_mesh(8, 4, false, 1.0, DVec3::ZERO), "t", "m").unwrap();
    assert!(fitted_sphere(&g).is_none());
    let area: f64 = g.parts.iter().map(|p| p.shape.area()).sum();
    assert!((area - Shape::Mesh(sphere_mesh(8, 4, false, 1.0, DVec3::ZERO)).area()).abs() < 1e-12);
    // Open: the northern cap without its fan.
    let (p, t) = fixtures::uv_sphere(1.0, 72, 36, false);
    let open: Vec<[u32; 3]> = t.into_iter().filter(|t| !t.contains(&0)).collect();
    let g = group_mesh(&mesh(p.clone(), &open), "t", "m").unwrap();
    assert!(g.parts.iter().all(|x| !matches!(x.shape, Shape::Patch(_))));
    // A spheroid 1e-4 off a sphere: vertices beyond the 1e-5 tolerance.
    let squashed: Vec<DVec3> = p.iter().map(|q| q * DVec3::new(1.0, 1.0, 1.0001)).collect();
    let (_, t) = fixtures::uv_sphere(1.0, 72, 36, false);
    let g = group_mesh(&mesh(squashed, &t), "t", "m").unwrap();
    assert!(g.parts.iter().all(|x| !matches!(x.shape, Shape::Patch(_))));
    // Two separate spheres in one mesh: two closed components, two spheres.
    let mut p2 = p.clone();
    p2.extend(p.iter().map(|q| *q + DVec3::new(5.0, 0.0, 0.0)));
    let mut t2 = t.clone();
    let n = p.len() as u32;
    t2.extend(t.iter().map(|x| x.map(|i| i + n)));
    let g = group_mesh(&mesh(p2, &t2), "t", "m").unwrap();
    let names: Vec<&str> = g.parts.iter().map(|x| x.suffix.as_str()).collect();
    assert_eq!(names, [".sphere0", ".sphere1"]);
}

/// A `nx × ny` grid of unit quads in the plane `z = 0` with every quad's four vertices
/// its own copies, each moved by up to `jitter` (deterministically), then scaled and
/// moved.
fn jittered_grid(nx: u32, ny: u32, jitter: f64, scale: f64, offset: DVec3) -> TriangleMesh {
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    let mut k = 0u32;
    for j in 0..ny {
        for i in 0..nx {
            let base = positions.len() as u32;
            for (x, y) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)] {
                k += 1;
                // A fixed pseudo-random direction per copy.
                let a = f64::from(k) * 2.399_963;
                let d = DVec3::new(a.cos(), a.sin(), (0.7 * a).sin()) * jitter;
                let on_border = x == 0 || y == 0 || x == nx || y == ny;
                let d = if on_border { DVec3::ZERO } else { d };
                positions.push(offset + scale * (DVec3::new(f64::from(x), f64::from(y), 0.0) + d));
            }
            tris.push([base, base + 1, base + 2]);
            tris.push([base, base + 2, base + 3]);
        }
    }
    mesh(positions, &tris)
}

#[test]
fn near_duplicate_vertices_are_welded_at_every_scale() {
    for e in -4..=4 {
        let s = 10f64.powi(e);
        let offset = DVec3::new(-2.0, 7.0, 1.0) * s;
        // Copies 1e-8 of the mesh size apart (f32 rounding of separately computed
        // positions) are the same vertex: one rectangle.
        let g = group_mesh(&jittered_grid(4, 3, 5e-8, s, offset), "t", "m").unwrap();
        assert!(g.warnings.is_empty(), "scale {s}: {:?}", g.warnings);
        match &g.parts[..] {
            [part] => match &part.shape {
                Shape::Parallelogram { edge_u, edge_v, .. } => {
                    let a = edge_u.cross(*edge_v).length();
                    assert!((a - 12.0 * s * s).abs() < 1e-9 * s * s, "scale {s}: {a}");
                }
                other => panic!("scale {s}: expected the rectangle, got {other:?}"),
            },
            parts => panic!("scale {s}: {} parts", parts.len()),
        }
        // Copies 1e-4 apart are different vertices: nothing connects, every quad stays
        // its own pair of triangles.
        let g = group_mesh(&jittered_grid(4, 3, 1e-4, s, offset), "t", "m").unwrap();
        assert_eq!(g.grouped_triangles, 0, "scale {s}");
    }
}

#[test]
fn triangles_that_welding_collapses_are_dropped_with_a_warning() {
    // A fan square with a sliver between two fan triangles: its far vertex is 1e-8
    // (of the size) from a square corner, so welding collapses it.
    let v = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    let positions = vec![
        v(0.0, 0.0),
        v(2.0, 0.0),
        v(2.0, 2.0),
        v(0.0, 2.0),
        v(1.0, 1.0),
        v(2.0, 1e-8),
    ];
    let tris = [[0, 1, 4], [5, 2, 4], [1, 5, 4], [2, 3, 4], [3, 0, 4]];
    let g = group_mesh(&mesh(positions, &tris), "t", "m").unwrap();
    assert!(
        matches!(
            &g.warnings[..],
            [WarningKind::WeldedTrianglesDropped { count: 1, area }] if *area < 1e-8
        ),
        "{:?}",
        g.warnings
    );
    assert_eq!(g.parts.len(), 1);
    assert!((g.parts[0].shape.area() - 4.0).abs() < 1e-7);
}

/// A square `[0,2]²` as a fan around its centre, one fan triangle split at the
/// midpoint of an edge it shares with its neighbour (a T-junction).
fn t_junction_square(scale: f64, offset: DVec3) -> TriangleMesh {
    let v = |x: f64, y: f64| offset + scale * DVec3::new(x, y, 0.0);
    let (a, b, c, d, o, m) = (0, 1, 2, 3, 4, 5);
    mesh(
        vec![
            v(0.0, 0.0),
            v(2.0, 0.0),
            v(2.0, 2.0),
            v(0.0, 2.0),
            v(1.0, 1.0),
            v(1.5, 0.5),
        ],
        &[[a, b, o], [b, c, m], [m, c, o], [c, d, o], [d, a, o]],
    )
}

#[test]
fn t_junctions_are_closed() {
    let g = group_mesh(&t_junction_square(1.0, DVec3::ZERO), "t", "m").unwrap();
    assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    assert_eq!(g.parts.len(), 1);
    assert_eq!(g.grouped_triangles, 5);
    match &g.parts[0].shape {
        Shape::Parallelogram { edge_u, edge_v, .. } => {
            assert!((edge_u.cross(*edge_v).length() - 4.0).abs() < 1e-12);
            assert!(edge_u.cross(*edge_v).z > 0.0);
        }
        other => panic!("expected the square, got {other:?}"),
    }
}

#[test]
fn split_vertices_and_grids_collapse_to_the_rectangle() {
    // A 4 × 3 grid of quads with every quad's vertices duplicated (as at UV seams).
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for j in 0..3 {
        for i in 0..4 {
            let base = positions.len() as u32;
            for (x, y) in [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)] {
                positions.push(DVec3::new(f64::from(x) * 0.5, f64::from(y) * 0.25, 1.0));
            }
            tris.push([base, base + 1, base + 2]);
            tris.push([base, base + 2, base + 3]);
        }
    }
    let g = group_mesh(&mesh(positions, &tris), "t", "m").unwrap();
    assert_eq!(g.parts.len(), 1);
    match &g.parts[0].shape {
        Shape::Parallelogram { edge_u, edge_v, .. } => {
            assert!((edge_u.cross(*edge_v) - DVec3::new(0.0, 0.0, 1.5)).length() < 1e-12)
        }
        other => panic!("expected one rectangle, got {other:?}"),
    }
}

#[test]
fn a_fan_winding_past_a_full_turn_falls_back_to_triangles() {
    // Eight 60° fan triangles around the origin: 480°, part of the plane covered
    // twice. Connected, coplanar and consistently oriented, but no polygon.
    let mut positions = vec![DVec3::ZERO];
    for k in 0..=8 {
        let a = f64::from(k) * TAU / 6.0;
        let r = 1.0 + 0.1 * f64::from(k);
        positions.push(r * DVec3::new(a.cos(), a.sin(), 0.0));
    }
    let tris: Vec<[u32; 3]> = (1..=8).map(|k| [0, k, k + 1]).collect();
    let m = mesh(positions, &tris);
    let g = group_mesh(&m, "t", "m").unwrap();
    assert_eq!(g.grouped_triangles, 0);
    assert!(
        matches!(
            &g.warnings[..],
            [WarningKind::GroupingFallback { triangles: 8, .. }]
        ),
        "{:?}",
        g.warnings
    );
    let Shape::Mesh(rest) = &g.parts[0].shape else {
        panic!("expected the triangles back")
    };
    assert_eq!(rest.triangle_count(), 8);
    assert!((g.parts[0].shape.area() - Shape::Mesh(m).area()).abs() < 1e-12);
}

#[test]
fn non_manifold_edges_are_not_crossed() {
    // A square fan plus a duplicate of one fan triangle: the duplicate's edges have
    // three owners or repeat a direction, so the three clean triangles form the square
    // minus the duplicated one, and both copies stay triangles. Area is kept.
    let v = |x: f64, y: f64| DVec3::new(x, y, 0.0);
    let positions = vec![
        v(0.0, 0.0),
        v(2.0, 0.0),
        v(2.0, 2.0),
        v(0.0, 2.0),
        v(1.0, 1.0),
    ];
    let tris = [[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4], [0, 1, 4]];
    let m = mesh(positions, &tris);
    let g = group_mesh(&m, "t", "m").unwrap();
    assert_eq!(g.grouped_triangles, 3);
    let total: f64 = g.parts.iter().map(|p| p.shape.area()).sum();
    assert!((total - 5.0).abs() < 1e-12, "{total}");
    let names: Vec<&str> = g.parts.iter().map(|p| p.suffix.as_str()).collect();
    assert_eq!(names, [".face0", ".rest"]);
}

#[test]
fn folded_and_non_coplanar_neighbours_stay_apart() {
    // Two squares (fans of 4) meeting at a 90° edge: two polygons, no warning.
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for (o, u, w) in [
        (DVec3::ZERO, DVec3::X, DVec3::Y),
        (DVec3::ZERO, DVec3::Z, DVec3::X),
    ] {
        let base = positions.len() as u32;
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.5)] {
            positions.push(o + x * u + y * w);
        }
        for k in 0..4 {
            tris.push([base + k, base + (k + 1) % 4, base + 4]);
        }
    }
    let g = group_mesh(&mesh(positions, &tris), "t", "m").unwrap();
    assert!(g.warnings.is_empty());
    assert_eq!(g.grouped_triangles, 8);
    assert_eq!(g.parts.len(), 2);
    for p in &g.parts {
        assert!(matches!(p.shape, Shape::Parallelogram { .. }));
        assert!((p.shape.area() - 1.0).abs() < 1e-12);
    }
}

/// The ring disk scaled, rotated and moved: still one disk of the scaled radius.
fn check_disk_at(scale: f64, angle: f64, offset: DVec3) {
    let (p, t) = fixtures::ring_disk(DVec3::ZERO, DVec3::X, DVec3::Y, 1.0, 128, 8);
    let m = DMat4::from_translation(offset)
        * DMat4::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), angle)
        * DMat4::from_scale(DVec3::splat(scale));
    let p: Vec<DVec3> = p.into_iter().map(|x| m.transform_point3(x)).collect();
    let built = TriangleMesh::build(p, Vec::new(), &t, "t", "m").unwrap();
    assert_eq!(built.dropped, 128);
    let g = group_mesh(&built.mesh, "t", "m").unwrap();
    assert!(g.warnings.is_empty(), "scale {scale}: {:?}", g.warnings);
    assert_eq!(g.parts.len(), 1, "scale {scale}");
    let (_, r) = disk_of(&g.parts[0].shape).unwrap_or_else(|| panic!("scale {scale}: not a disk"));
    assert!(
        (r - scale).abs() < 1e-9 * scale,
        "scale {scale}: radius {r}"
    );
    let exact = std::f64::consts::PI * scale * scale;
    let got = g.parts[0].shape.area();
    assert!(
        (got - exact).abs() < 1e-9 * exact,
        "scale {scale}: {got} vs {exact}"
    );
}

#[test]
fn grouping_is_scale_invariant_from_1e_minus_4_to_1e4() {
    for e in -4..=4 {
        let s = 10f64.powi(e);
        check_disk_at(s, 0.7, DVec3::new(3.0, -1.0, 2.0) * s);
        let g = group_mesh(&t_junction_square(s, DVec3::splat(5.0 * s)), "t", "m").unwrap();
        assert!(g.warnings.is_empty(), "scale {s}: {:?}", g.warnings);
        assert_eq!(g.grouped_triangles, 5, "scale {s}");
    }
}

/// A mesh surface in a scene (for the loader round trips).
fn scene_with(shape: Shape) -> Scene {
    let mut s = Scene::new("t");
    let m = s.add_material(wavelux_scene::Material::lambertian(
        "m",
        wavelux_scene::Rgb::grey(0.5),
        wavelux_scene::Rgb::BLACK,
    ));
    s.add_surface(Surface {
        name: "box".into(),
        shape,
        material: m,
        sides: Sidedness::OneSided,
    });
    s
}

#[test]
fn one_mesh_with_several_faces_names_every_part() {
    // Two fan squares meeting at 90° in one primitive, plus a lone triangle.
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for (o, u, w) in [
        (DVec3::ZERO, DVec3::X, DVec3::Y),
        (DVec3::ZERO, DVec3::Z, DVec3::X),
    ] {
        let base = positions.len() as u32;
        for (x, y) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0), (0.5, 0.5)] {
            positions.push(o + x * u + y * w);
        }
        for k in 0..4 {
            tris.push([base + k, base + (k + 1) % 4, base + 4]);
        }
    }
    let base = positions.len() as u32;
    positions.extend([
        DVec3::new(5.0, 0.0, 0.0),
        DVec3::new(6.0, 0.0, 0.0),
        DVec3::new(5.0, 0.0, 1.0),
    ]);
    tris.push([base, base + 2, base + 1]);
    let s = roundtrip(
        &scene_with(Shape::Mesh(mesh(positions, &tris))),
        MeshGrouping::Surfaces,
    );
    let names: Vec<&str> = s.surfaces.iter().map(|x| x.name.as_str()).collect();
    assert_eq!(names, ["box.face0", "box.face1", "box.rest"]);
    assert!((s.total_area() - 2.5).abs() < 1e-6);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(48))]

    /// A random star-shaped polygon, fan-triangulated from its centre and moved
    /// anywhere at any scale, comes back as itself: same area and vertex count when
    /// no vertex runs straight within twice the straightening tolerance
    /// (`COPLANAR_REL` × the group's diagonal); otherwise (a random polygon can have
    /// nearly straight vertices: CI drew one) the area within the documented bound,
    /// 4 × tolerance × perimeter, and no more vertices than it had.
    #[test]
    fn fans_of_random_star_polygons_round_trip(
        radii in proptest::collection::vec(0.3f64..1.0, 5..40),
        scale_exp in -4i32..=4,
        angle in 0.0f64..6.0,
    ) {
        let n = radii.len() as u32;
        let scale = 10f64.powi(scale_exp);
        let rot = DMat4::from_axis_angle(DVec3::new(0.3, -1.0, 0.5).normalize(), angle)
            * DMat4::from_scale(DVec3::splat(scale));
        let mut positions = vec![rot.transform_point3(DVec3::ZERO)];
        let mut area = 0.0;
        for (k, r) in radii.iter().enumerate() {
            let a = TAU * k as f64 / f64::from(n);
            positions.push(rot.transform_point3(*r * DVec3::new(a.cos(), a.sin(), 0.0)));
            let r2 = radii[(k + 1) % radii.len()];
            area += 0.5 * r * r2 * (TAU / f64::from(n)).sin() * scale * scale;
        }
        let tris: Vec<[u32; 3]> = (1..=n).map(|k| [0, k, k % n + 1]).collect();
        // The straightening tolerance, and how far each rim vertex is from the chord
        // of its two neighbours.
        let lo = positions.iter().fold(DVec3::splat(f64::INFINITY), |a, &p| a.min(p));
        let hi = positions.iter().fold(DVec3::splat(f64::NEG_INFINITY), |a, &p| a.max(p));
        let tol = wavelux_scene::group::COPLANAR_REL * (hi - lo).length();
        let rim = &positions[1..];
        let m = rim.len();
        let mut perimeter = 0.0;
        let mut straightest = f64::INFINITY;
        for k in 0..m {
            let (a, q, c) = (rim[(k + m - 1) % m], rim[k], rim[(k + 1) % m]);
            perimeter += (c - q).length();
            straightest = straightest.min((q - a).cross(c - a).length() / (c - a).length());
        }
        let g = group_mesh(&mesh(positions, &tris), "t", "m").unwrap();
        // A star of 16 or more vertices whose radii all lie within 25 % of their fitted
        // circle is a documented near miss (`fit::NEAR_MISS_REL`) and says so; no other
        // warning (a fallback to triangles above all) is allowed.
        let others: Vec<_> = g
            .warnings
            .iter()
            .filter(|w| !matches!(w, WarningKind::CurveNotRecognised { .. }))
            .collect();
        prop_assert!(others.is_empty(), "{:?}", others);
        prop_assert_eq!(g.parts.len(), 1);
        let got = g.parts[0].shape.area();
        let exact = straightest > 2.0 * tol;
        let bound = if exact { 1e-9 * area } else { 4.0 * tol * perimeter + 1e-9 * area };
        prop_assert!((got - area).abs() <= bound, "{} vs {} (bound {})", got, area, bound);
        if let Shape::Polygon(p) = &g.parts[0].shape {
            prop_assert!(p.outer.edges.len() <= n as usize);
            prop_assert!(p.outer.edges.len() >= 3);
            if exact {
                prop_assert_eq!(p.outer.edges.len(), n as usize);
            }
        }
    }
}

// ---------------------------------------------------------------------------------
// Curved surfaces: disks, annuli and cylinders recognised; near misses say why.
// ---------------------------------------------------------------------------------

/// Scale, rotate (about an oblique axis) and move.
fn placed(scale: f64, offset: DVec3) -> DMat4 {
    DMat4::from_translation(offset)
        * DMat4::from_axis_angle(DVec3::new(1.0, 2.0, 3.0).normalize(), 0.7)
        * DMat4::from_scale(DVec3::splat(scale))
}

fn moved(m: DMat4, p: Vec<DVec3>) -> Vec<DVec3> {
    p.into_iter().map(|x| m.transform_point3(x)).collect()
}

/// Quads `(k, j)–(k, j+1)–(k+1, j+1)–(k+1, j)` of a `rows × cols` vertex grid (vertex
/// `(k, j)` at `k·cols + j`, columns wrapping when `wrap`), split in two triangles,
/// front side `∂j × ∂k` (or the other one when `flip`).
fn grid_tris(rows: u32, cols: u32, wrap: bool, flip: bool) -> Vec<[u32; 3]> {
    let id = |k: u32, j: u32| k * cols + j % cols;
    let mut t = Vec::new();
    for k in 0..rows - 1 {
        for j in 0..if wrap { cols } else { cols - 1 } {
            let (a, b, c, d) = (id(k, j), id(k, j + 1), id(k + 1, j + 1), id(k + 1, j));
            if flip {
                t.push([a, c, b]);
                t.push([a, d, c]);
            } else {
                t.push([a, b, c]);
                t.push([a, c, d]);
            }
        }
    }
    t
}

/// Points `radius(k, θ)·(cos θ, sin θ) + height(k)·z` on `rows` rings of `sectors`
/// segments over `span` radians (a full turn wraps).
fn rings(
    rows: u32,
    sectors: u32,
    span: f64,
    f: impl Fn(u32, u32, f64) -> (f64, f64),
) -> Vec<DVec3> {
    let cols = if span >= TAU { sectors } else { sectors + 1 };
    let mut p = Vec::new();
    for k in 0..rows {
        for j in 0..cols {
            let a = span * f64::from(j) / f64::from(sectors);
            let (r, z) = f(k, j, a);
            p.push(DVec3::new(r * a.cos(), r * a.sin(), z));
        }
    }
    p
}

/// An annulus `r0..r1` in `z = 0` facing `+z` (a disk when `r0 = 0`; its degenerate
/// centre triangles are dropped by the mesh builder).
fn annulus(r0: f64, r1: f64, sectors: u32, steps: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = rings(steps + 1, sectors, TAU, |k, _, _| {
        (r0 + (r1 - r0) * f64::from(k) / f64::from(steps), 0.0)
    });
    // Rows run outwards: ∂k × ∂j is +z, so flip the grid's ∂j × ∂k.
    (p, grid_tris(steps + 1, sectors, true, true))
}

/// An open cylinder of radius 1 and height `h` about `z` over `span` radians, facing
/// outwards (inwards when `inward`).
fn tube(sectors: u32, stacks: u32, span: f64, h: f64, inward: bool) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = rings(stacks + 1, sectors, span, |k, _, _| {
        (1.0, h * f64::from(k) / f64::from(stacks))
    });
    let cols = if span >= TAU { sectors } else { sectors + 1 };
    (p, grid_tris(stacks + 1, cols, span >= TAU, inward))
}

fn curve_warnings(g: &wavelux_scene::Grouped) -> Vec<(String, String)> {
    g.warnings
        .iter()
        .filter_map(|w| match w {
            WarningKind::CurveNotRecognised {
                surface, reason, ..
            } => Some((surface.clone(), reason.clone())),
            _ => None,
        })
        .collect()
}

#[test]
fn tessellated_disks_are_disks_from_16_to_512_segments_at_every_scale() {
    for sectors in [16, 17, 40, 128, 512] {
        for e in [-4, -1, 0, 2, 4] {
            let s = 10f64.powi(e);
            let offset = DVec3::new(3.0, -1.0, 2.0) * s;
            let m = placed(s, offset);
            let (p, t) = annulus(0.0, 1.0, sectors, 2);
            let g = group_mesh(&mesh(moved(m, p), &t), "t", "m").unwrap();
            assert!(g.warnings.is_empty(), "{sectors} at {s}: {:?}", g.warnings);
            let [part] = &g.parts[..] else {
                panic!("{sectors} at {s}: {} parts", g.parts.len())
            };
            let (c, r) = disk_of(&part.shape)
                .unwrap_or_else(|| panic!("{sectors} at {s}: not a disk: {:?}", part.shape));
            assert!((r - s).abs() < 1e-9 * s, "{sectors} at {s}: radius {r}");
            let centre = polygon(&part.shape).frame.point(c);
            assert!(
                (centre - offset).length() < 1e-9 * s,
                "{sectors} at {s}: {centre}"
            );
            let normal = polygon(&part.shape).frame.normal();
            assert!((normal - m.transform_vector3(DVec3::Z) / s).length() < 1e-9);
            let exact = std::f64::consts::PI * s * s;
            assert!((part.shape.area() - exact).abs() < 1e-9 * exact);
        }
    }
}

#[test]
fn annuli_are_disks_with_a_round_hole() {
    for sectors in [16, 64, 512] {
        for e in [-4, 0, 4] {
            let s = 10f64.powi(e);
            let (p, t) = annulus(0.4, 1.0, sectors, 3);
            let g = group_mesh(
                &mesh(moved(placed(s, DVec3::splat(7.0 * s)), p), &t),
                "t",
                "m",
            )
            .unwrap();
            assert!(g.warnings.is_empty(), "{sectors} at {s}: {:?}", g.warnings);
            let [part] = &g.parts[..] else {
                panic!("{} parts", g.parts.len())
            };
            let poly = polygon(&part.shape);
            assert!(
                matches!(poly.outer.edges[..], [LoopEdge::Arc { ccw: true, .. }]),
                "{sectors} at {s}: {:?}",
                poly.outer
            );
            let [hole] = &poly.holes[..] else {
                panic!("{} holes", poly.holes.len())
            };
            let [
                LoopEdge::Arc {
                    start,
                    center,
                    ccw: false,
                },
            ] = hole.edges[..]
            else {
                panic!("{sectors} at {s}: hole {hole:?}")
            };
            assert!(((start - center).length() - 0.4 * s).abs() < 1e-9 * s);
            let exact = std::f64::consts::PI * (1.0 - 0.16) * s * s;
            assert!(
                (part.shape.area() - exact).abs() < 1e-9 * exact,
                "{sectors} at {s}"
            );
        }
    }
}

/// A recognised cylinder: placement, radius, azimuth and height ranges.
type Cylinder = (wavelux_scene::Placement, f64, (f64, f64), (f64, f64));

fn cylinder_of(part: &wavelux_scene::MeshPart) -> Option<Cylinder> {
    let Shape::Patch(p) = &part.shape else {
        return None;
    };
    match p.surface {
        AnalyticSurface::Cylinder {
            placement,
            radius,
            azimuth,
            height,
        } => Some((placement, radius, azimuth, height)),
        _ => None,
    }
}

#[test]
fn tessellated_tubes_and_half_pipes_are_cylinders_at_every_scale() {
    for sectors in [16, 64, 512] {
        for stacks in [1, 3] {
            for span in [TAU, std::f64::consts::PI] {
                for inward in [false, true] {
                    for e in [-4, 0, 4] {
                        let s = 10f64.powi(e);
                        let m = placed(s, DVec3::new(-2.0, 5.0, 1.0) * s);
                        let (p, t) = tube(sectors, stacks, span, 2.0, inward);
                        let g = group_mesh(&mesh(moved(m, p), &t), "t", "m").unwrap();
                        let what = format!(
                            "{sectors}×{stacks}, span {span:.2}, inward {inward}, scale {s}"
                        );
                        assert!(g.warnings.is_empty(), "{what}: {:?}", g.warnings);
                        let [part] = &g.parts[..] else {
                            panic!("{what}: {} parts", g.parts.len())
                        };
                        let (pl, r, az, h) =
                            cylinder_of(part).unwrap_or_else(|| panic!("{what}: {:?}", part.shape));
                        assert!((r - s).abs() < 1e-9 * s, "{what}: radius {r}");
                        assert!(
                            ((h.1 - h.0) - 2.0 * s).abs() < 1e-9 * s,
                            "{what}: height {h:?}"
                        );
                        assert!(
                            ((az.1 - az.0) - span).abs() < 1e-9,
                            "{what}: azimuth {az:?}"
                        );
                        let axis = m.transform_vector3(DVec3::Z) / s;
                        assert!(
                            pl.axis.cross(axis).length() < 1e-9,
                            "{what}: axis {}",
                            pl.axis
                        );
                        assert_eq!(part.reversed, inward, "{what}");
                        let exact = span * 2.0 * s * s;
                        assert!((part.shape.area() - exact).abs() < 1e-9 * exact, "{what}");
                        assert_eq!(g.grouped_triangles, t.len(), "{what}");
                    }
                }
            }
        }
    }
}

#[test]
fn a_capped_tube_from_a_glb_is_a_cylinder_and_two_disks() {
    // One mesh: the tube and its two caps (own vertices, welded at the rims), through
    // a GLB file (f32 positions).
    let (mut p, mut t) = tube(64, 2, TAU, 1.5, false);
    for (z, flip) in [(0.0, true), (1.5, false)] {
        let (cp, ct) = annulus(0.0, 1.0, 64, 2);
        let base = p.len() as u32;
        p.extend(cp.into_iter().map(|q| q + DVec3::new(0.0, 0.0, z)));
        // The bottom cap faces −z.
        t.extend(ct.into_iter().map(|x| {
            let x = x.map(|i| i + base);
            if flip { [x[0], x[2], x[1]] } else { x }
        }));
    }
    let m = placed(3.0, DVec3::new(1.0, 2.0, 3.0));
    let s = roundtrip(
        &scene_with(Shape::Mesh(mesh(moved(m, p), &t))),
        MeshGrouping::Surfaces,
    );
    let kinds: Vec<(&str, bool)> = s
        .surfaces
        .iter()
        .map(|x| (x.name.as_str(), matches!(x.shape, Shape::Patch(_))))
        .collect();
    assert_eq!(
        kinds,
        [
            ("box.cylinder0", true),
            ("box.face0", false),
            ("box.face1", false)
        ],
        "{:?}",
        s.warnings
    );
    for f in &s.surfaces[1..] {
        let (_, r) = disk_of(&f.shape).unwrap_or_else(|| panic!("{}: {:?}", f.name, f.shape));
        assert!((r - 3.0).abs() < 1e-5, "{}: {r}", f.name);
    }
    let exact = (TAU * 1.5 + TAU) * 9.0;
    assert!(
        (s.total_area() - exact).abs() < 1e-5 * exact,
        "{}",
        s.total_area()
    );
}

#[test]
fn near_circles_stay_polygons_and_say_why() {
    // An ellipse (semi-axes 1 and 0.9), a jittered circle (radii ± 1e-3) and a
    // jittered tube: kept as they are, each with a warning naming the surface it
    // nearly is (a slightly tapered tube is a cone: see the cone tests); coarse
    // polygons and prisms (meant as such) stay silently.
    let ellipse: Vec<DVec3> = annulus(0.0, 1.0, 64, 2)
        .0
        .into_iter()
        .map(|q| q * DVec3::new(1.0, 0.9, 1.0))
        .collect();
    let t = annulus(0.0, 1.0, 64, 2).1;
    let jitter: Vec<DVec3> = rings(3, 64, TAU, |k, j, _| {
        (
            0.5 * f64::from(k) * (1.0 + 1e-3 * (7.3 * f64::from(j)).sin()),
            0.0,
        )
    });
    for (what, p) in [("ellipse", ellipse), ("jittered", jitter)] {
        let g = group_mesh(&mesh(p, &t), "t", "m").unwrap();
        let [part] = &g.parts[..] else {
            panic!("{what}: {} parts", g.parts.len())
        };
        assert_eq!(polygon(&part.shape).outer.edges.len(), 64, "{what}");
        let w = curve_warnings(&g);
        assert_eq!(w.len(), 1, "{what}: {:?}", g.warnings);
        assert_eq!(w[0].0, "disk", "{what}");
        assert!(
            w[0].1.contains("from the best circle"),
            "{what}: {}",
            w[0].1
        );
    }
    let jittered_tube = rings(5, 64, TAU, |k, j, _| {
        (
            1.0 + 1e-3 * (7.3 * f64::from(j + 3 * k)).sin(),
            0.5 * f64::from(k),
        )
    });
    let t = grid_tris(5, 64, true, false);
    {
        let (what, p) = ("jittered tube", jittered_tube);
        let m = mesh(p, &t);
        let area = Shape::Mesh(m.clone()).area();
        let g = group_mesh(&m, "t", "m").unwrap();
        assert!(g.parts.iter().all(|x| cylinder_of(x).is_none()), "{what}");
        let got: f64 = g.parts.iter().map(|x| x.shape.area()).sum();
        assert!((got - area).abs() < 1e-9 * area, "{what}");
        let w = curve_warnings(&g);
        assert_eq!(w.len(), 1, "{what}: {:?}", g.warnings);
        assert_eq!(w[0].0, "cylinder", "{what}");
        assert!(
            w[0].1.contains("from the best cylinder"),
            "{what}: {}",
            w[0].1
        );
    }
    // A tube with a window (two quads missing): its facets do not cover the patch.
    let (p, mut t) = tube(32, 3, TAU, 1.0, false);
    t.drain(2 * 32 + 4..2 * 32 + 8);
    let g = group_mesh(&mesh(p, &t), "t", "m").unwrap();
    assert!(g.parts.iter().all(|x| cylinder_of(x).is_none()));
    let w = curve_warnings(&g);
    assert_eq!(w.len(), 1, "{:?}", g.warnings);
    assert!(w[0].1.contains("cover"), "{}", w[0].1);
    // Meant as polygons and prisms: a 12-gon, an 8-sided prism.
    let (p, t) = annulus(0.0, 1.0, 12, 1);
    let g = group_mesh(&mesh(p, &t), "t", "m").unwrap();
    assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    assert_eq!(polygon(&g.parts[0].shape).outer.edges.len(), 12);
    let (p, t) = tube(8, 3, TAU, 1.0, false);
    let g = group_mesh(&mesh(p, &t), "t", "m").unwrap();
    assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    assert!(g.parts.iter().all(|x| cylinder_of(x).is_none()));
}

/// A recognised cone: apex, unit axis (apex towards the patch), radius per unit height,
/// azimuth span, and the patch's nearest and farthest heights from the apex.
type Cone = (DVec3, DVec3, f64, f64, (f64, f64));

fn cone_of(part: &wavelux_scene::MeshPart) -> Option<Cone> {
    let Shape::Patch(p) = &part.shape else {
        return None;
    };
    match p.surface {
        AnalyticSurface::Cone {
            placement,
            radius,
            height,
            azimuth,
            generator,
        } => Some((
            placement.origin,
            placement.axis.normalize(),
            radius / height,
            azimuth.1 - azimuth.0,
            (generator.0 * height, generator.1 * height),
        )),
        _ => None,
    }
}

/// A frustum about `z` from radius `r0` at `z = 0` to `r1` at `z = h` over `span`
/// radians, facing outwards (inwards when `inward`).
fn frustum(
    r0: f64,
    r1: f64,
    h: f64,
    stacks: u32,
    sectors: u32,
    span: f64,
    inward: bool,
) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let p = rings(stacks + 1, sectors, span, |k, _, _| {
        let f = f64::from(k) / f64::from(stacks);
        (r0 + (r1 - r0) * f, h * f)
    });
    let cols = if span >= TAU { sectors } else { sectors + 1 };
    (p, grid_tris(stacks + 1, cols, span >= TAU, inward))
}

#[test]
fn tessellated_cones_are_cones_at_every_scale() {
    // Frusta narrowing upwards (apex above) and widening (apex below), from a slight
    // taper (1 → 0.9 over 2) to nearly the tip (1 → 0.05), full and partial turns.
    for (r0, r1) in [(1.0, 0.9), (1.0, 0.4), (0.3, 1.2), (1.0, 0.05)] {
        for sectors in [16, 64, 256] {
            for span in [TAU, 2.0] {
                for inward in [false, true] {
                    for e in [-4, 0, 4] {
                        let s = 10f64.powi(e);
                        let m = placed(s, DVec3::new(4.0, -3.0, 2.0) * s);
                        let (p, t) = frustum(r0, r1, 2.0, 3, sectors, span, inward);
                        let g = group_mesh(&mesh(moved(m, p), &t), "t", "m").unwrap();
                        let what = format!(
                            "{r0} → {r1}, {sectors} sectors, span {span:.2}, inward {inward}, scale {s}"
                        );
                        assert!(g.warnings.is_empty(), "{what}: {:?}", g.warnings);
                        let [part] = &g.parts[..] else {
                            panic!("{what}: {} parts", g.parts.len())
                        };
                        let (apex, axis, slope, az, h) =
                            cone_of(part).unwrap_or_else(|| panic!("{what}: {:?}", part.shape));
                        // Apex on the axis where the radius reaches 0.
                        let z_apex = 2.0 * r0 / (r0 - r1);
                        let want_apex = m.transform_point3(DVec3::new(0.0, 0.0, z_apex));
                        assert!(
                            (apex - want_apex).length() < 1e-7 * s * z_apex.abs(),
                            "{what}: apex {apex} vs {want_apex}"
                        );
                        let up = m.transform_vector3(DVec3::Z) / s;
                        let want_axis = if z_apex > 0.0 { -up } else { up };
                        assert!((axis - want_axis).length() < 1e-9, "{what}: axis {axis}");
                        let want_slope = (r0 - r1).abs() / 2.0;
                        assert!(
                            (slope - want_slope).abs() < 1e-9 * want_slope,
                            "{what}: slope {slope}"
                        );
                        assert!((az - span).abs() < 1e-9, "{what}: azimuth span {az}");
                        let (near, far) = (r0.min(r1), r0.max(r1));
                        let want_h = (near / want_slope, far / want_slope);
                        assert!(
                            (h.0 - want_h.0 * s).abs() < 1e-7 * s * want_h.1
                                && (h.1 - want_h.1 * s).abs() < 1e-7 * s * want_h.1,
                            "{what}: heights {h:?} vs {want_h:?}"
                        );
                        assert_eq!(part.reversed, inward, "{what}");
                        // Lateral area of the frustum part: span/2 (r0 + r1) · slant.
                        let exact = 0.5 * span * (r0 + r1) * (r0 - r1).hypot(2.0) * s * s;
                        assert!(
                            (part.shape.area() - exact).abs() < 1e-9 * exact,
                            "{what}: area {} vs {exact}",
                            part.shape.area()
                        );
                        // The patch's front side faces away from the axis, and its
                        // points lie on the input cone.
                        let Shape::Patch(patch) = &part.shape else {
                            unreachable!()
                        };
                        let map = patch.surface.parametrization("t", "m").unwrap();
                        for uv in [glam::DVec2::new(0.3, 0.2), glam::DVec2::new(0.8, 0.9)] {
                            let sp = map.eval(uv);
                            let local = m.inverse().transform_point3(sp.position);
                            let radial = DVec3::new(local.x, local.y, 0.0);
                            let want_r = r0 + (r1 - r0) * local.z / 2.0;
                            assert!((radial.length() - want_r).abs() < 1e-9, "{what}: {local}");
                            let n = m.inverse().transform_vector3(sp.normal);
                            assert!(n.dot(radial) > 0.0, "{what}: normal {n}");
                        }
                        assert_eq!(g.grouped_triangles, t.len(), "{what}");
                    }
                }
            }
        }
    }
}

#[test]
fn near_cones_stay_facets_and_say_why() {
    // A jittered frustum (radii ± 1e-3): a cone near miss; a barrel (radius bulging by
    // 5 % in the middle): near no cone or cylinder within the vertex tolerance, named
    // after the nearest candidate; too coarse (12 sectors): silently facets.
    let jittered = rings(5, 64, TAU, |k, j, _| {
        let f = f64::from(k) / 4.0;
        (
            (1.0 - 0.5 * f) * (1.0 + 1e-3 * (7.3 * f64::from(j + 3 * k)).sin()),
            2.0 * f,
        )
    });
    let t = grid_tris(5, 64, true, false);
    let m = mesh(jittered, &t);
    let area = Shape::Mesh(m.clone()).area();
    let g = group_mesh(&m, "t", "m").unwrap();
    assert!(g.parts.iter().all(|x| cone_of(x).is_none()));
    let got: f64 = g.parts.iter().map(|x| x.shape.area()).sum();
    assert!((got - area).abs() < 1e-9 * area);
    let w = curve_warnings(&g);
    assert_eq!(w.len(), 1, "{:?}", g.warnings);
    assert_eq!(w[0].0, "cone");
    assert!(w[0].1.contains("from the best cone"), "{}", w[0].1);
    let (p, t) = frustum(1.0, 0.5, 2.0, 3, 12, TAU, false);
    let g = group_mesh(&mesh(p, &t), "t", "m").unwrap();
    assert!(g.warnings.is_empty(), "{:?}", g.warnings);
    assert!(g.parts.iter().all(|x| cone_of(x).is_none()));
}

/// A rounded rectangle `w × h` (corner radius `r`, `arc` segments per corner) in `z =
/// 0`, facing `+z`, as a fan from its centre; and its outline.
fn rounded_rectangle(w: f64, h: f64, r: f64, arc: u32) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut p = vec![DVec3::ZERO];
    let corners = [
        (0.5 * w - r, 0.5 * h - r),
        (-0.5 * w + r, 0.5 * h - r),
        (-0.5 * w + r, -0.5 * h + r),
        (0.5 * w - r, -0.5 * h + r),
    ];
    for (q, (cx, cy)) in corners.into_iter().enumerate() {
        for k in 0..=arc {
            let a = (q as f64 + f64::from(k) / f64::from(arc)) * TAU / 4.0;
            p.push(DVec3::new(cx + r * a.cos(), cy + r * a.sin(), 0.0));
        }
    }
    // Where corners' arcs meet (a slot's ends), their common point once.
    p.dedup_by(|b, a| (*b - *a).length() < 1e-12);
    if (p[p.len() - 1] - p[1]).length() < 1e-12 {
        p.pop();
    }
    let n = p.len() as u32 - 1;
    let t = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    (p, t)
}

#[test]
fn rounded_corners_and_slots_become_arcs_at_every_scale() {
    use std::f64::consts::PI;
    for arc in [4, 8, 32] {
        for e in [-4, 0, 4] {
            let s = 10f64.powi(e);
            let m = placed(s, DVec3::new(1.0, 2.0, -3.0) * s);
            // A rounded rectangle, and a slot (a stadium: the corners' arcs meet).
            for (w, h, r) in [(3.0, 2.0, 0.4), (4.0, 1.0, 0.5)] {
                let (p, t) = rounded_rectangle(w, h, r, arc);
                let g = group_mesh(&mesh(moved(m, p), &t), "t", "m").unwrap();
                let what = format!("{w} × {h} r {r}, {arc} segments per corner, scale {s}");
                assert!(g.warnings.is_empty(), "{what}: {:?}", g.warnings);
                let [part] = &g.parts[..] else {
                    panic!("{what}: {} parts", g.parts.len())
                };
                let poly = polygon(&part.shape);
                let arcs: Vec<f64> = poly
                    .outer
                    .edges
                    .iter()
                    .filter_map(|e| match e {
                        LoopEdge::Arc { start, center, .. } => Some((*start - *center).length()),
                        LoopEdge::Segment { .. } => None,
                    })
                    .collect();
                // Corners meeting in a slot join into two half circles.
                let want = if 2.0 * r == h { 2 } else { 4 };
                assert_eq!(arcs.len(), want, "{what}: {:?}", poly.outer);
                assert!(arcs.iter().all(|&x| (x - r * s).abs() < 1e-9 * s), "{what}");
                let exact = (w * h - (4.0 - PI) * r * r) * s * s;
                assert!(
                    (part.shape.area() - exact).abs() < 1e-9 * exact,
                    "{what}: area {} vs {exact}",
                    part.shape.area()
                );
            }
        }
    }
    // Three segments per corner (30° each, coarser than a circle's facets) stay
    // segments, silently.
    // (With 16 vertices, the outline is a near-miss disk, as before.)
    let (p, t) = rounded_rectangle(3.0, 2.0, 0.4, 3);
    let g = group_mesh(&mesh(p, &t), "t", "m").unwrap();
    assert!(
        curve_warnings(&g).iter().all(|w| w.0 == "disk") && g.warnings.len() <= 1,
        "{:?}",
        g.warnings
    );
    let poly = polygon(&g.parts[0].shape);
    assert!(
        poly.outer
            .edges
            .iter()
            .all(|e| matches!(e, LoopEdge::Segment { .. })),
        "{:?}",
        poly.outer
    );
}
