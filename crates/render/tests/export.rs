//! Exports of masked (virtual) supports cover only the real part: the baked glTF's
//! triangles of a hexagon with a round hole add up to the polygon's area, not to its
//! enclosing parallelogram's, and the lightmaps' alpha channel integrates to the real
//! area exactly.

use glam::{DVec2, DVec3};
use wavelux_render::Image;
use wavelux_render::export::{write_gltf, write_lightmaps};
use wavelux_scene::{
    GltfOptions, Loop, Material, MeshGrouping, PlaneFrame, PolygonShape, Rgb, Scene, Shape,
    Sidedness, Surface, load_gltf,
};
use wavelux_solver::{BasisKind, SolverConfig, solve};

/// A regular hexagon of circumradius 1 with a hole of radius 0.3 (z = 0, facing +z)
/// under a square emitter.
fn scene() -> (Scene, f64) {
    let mut s = Scene::new("hexagon");
    let grey = s.add_material(Material::lambertian("grey", Rgb::grey(0.5), Rgb::BLACK));
    let light = s.add_material(Material::lambertian("light", Rgb::BLACK, Rgb::grey(1.0)));
    let hex: Vec<DVec2> = (0..6)
        .map(|k| {
            let a = std::f64::consts::TAU * f64::from(k) / 6.0 + 0.2;
            DVec2::new(a.cos(), a.sin())
        })
        .collect();
    let poly = PolygonShape {
        frame: PlaneFrame {
            origin: DVec3::ZERO,
            u: DVec3::X,
            v: DVec3::Y,
        },
        outer: Loop::polygon(&hex),
        holes: vec![Loop::circle(DVec2::new(0.1, 0.0), 0.3)],
    };
    let area = poly.area();
    s.add_surface(Surface {
        name: "hexagon".into(),
        shape: Shape::Polygon(poly),
        material: grey,
        sides: Sidedness::OneSided,
    });
    s.add_surface(Surface {
        name: "light".into(),
        shape: Shape::parallelogram(DVec3::new(-0.5, -0.5, 1.0), DVec3::Y, DVec3::X),
        material: light,
        sides: Sidedness::OneSided,
    });
    (s, area)
}

#[test]
fn exports_of_masked_supports_cover_only_the_real_part() {
    let (scene, area) = scene();
    let sol = solve(
        &scene,
        &SolverConfig {
            basis: BasisKind::Haar,
            max_level: 3,
            eps: 1e-3,
            ..SolverConfig::default()
        },
    )
    .unwrap();
    let hex = sol
        .patches
        .iter()
        .position(|p| p.surface == 0)
        .expect("hexagon patch");
    let support = &sol.patches[hex].support;
    assert!(
        support.mask.is_some(),
        "the hexagon should be a virtual support"
    );
    assert!(
        support.area > 1.1 * area,
        "enclosing parallelogram vs polygon"
    );
    let names = vec!["hexagon".to_string(), "light".to_string()];
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("baked.gltf");
    write_gltf(&sol, &names, &path, 2).unwrap();
    let back = load_gltf(
        &path,
        &GltfOptions {
            grouping: MeshGrouping::Triangles,
            ..GltfOptions::default()
        },
    )
    .unwrap();
    let got = back.surface("hexagon").unwrap().shape.area();
    // The hole is flattened with sagitta ≤ 1e-4 of the region's diagonal.
    assert!(
        (got - area).abs() < 1e-3 * area,
        "baked area {got} vs polygon {area}"
    );
    // Lightmaps: A = real fraction, so Σ A · (support area / res²) = real area.
    let res = 32;
    let maps = write_lightmaps(&sol, &names, dir.path(), res).unwrap();
    let map = maps
        .iter()
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("hexagon.")
        })
        .unwrap();
    let alpha = Image::read_exr_alpha(map).unwrap();
    let covered: f64 = alpha.iter().sum::<f64>() * support.area / (res * res) as f64;
    // f32 alpha: 1e-6 relative.
    assert!(
        (covered - area).abs() < 1e-5 * area,
        "lightmap coverage {covered} vs polygon {area}"
    );
    assert!(alpha.contains(&0.0) && alpha.contains(&1.0));
    // Every pixel's colour comes from a real point: no NaN, no virtual extension.
    let img = Image::read_exr(map).unwrap();
    assert!(
        img.pixels
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
    let light = maps
        .iter()
        .find(|p| {
            p.file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("light.")
        })
        .unwrap();
    assert!(
        Image::read_exr_alpha(light)
            .unwrap()
            .iter()
            .all(|&a| a == 1.0)
    );
}
