//! Punctual lights in the path tracer (next-event estimation), indirect-only estimates
//! and the meshless field, against closed forms.

use glam::DVec3;
use wavelux_meshless::{
    CpuBackend, DirectLighting, MeshlessConfig, Precomputed, Relighter, SceneSurfaces,
};
use wavelux_render::{
    Component, IndirectSource, MeshlessField, PathTracer, RadiosityField, ReferenceOptions, View,
    render,
};
use wavelux_scene::builtin::white_furnace;
use wavelux_scene::{Light, Material, Rgb, Scene, Shape, Sidedness, Surface};

/// A single grey floor `[-5, 5]² × {0}` (front up) under a spot.
fn floor_scene() -> Scene {
    let mut s = Scene::new("floor");
    let m = s.add_material(Material::lambertian("grey", Rgb::grey(0.6), Rgb::BLACK));
    s.add_surface(Surface {
        name: "floor".into(),
        shape: Shape::parallelogram(
            DVec3::new(-5.0, -5.0, 0.0),
            DVec3::X * 10.0,
            DVec3::Y * 10.0,
        ),
        material: m,
        sides: Sidedness::OneSided,
    });
    s.lights.push(Light::spot(
        "spot",
        DVec3::new(0.5, -0.2, 2.0),
        DVec3::new(0.1, 0.0, -1.0),
        0.4,
        0.9,
        Rgb::new(3.0, 2.0, 1.0),
    ));
    s
}

#[test]
fn punctual_light_on_a_lone_floor_is_exact() {
    let scene = floor_scene();
    let pt = PathTracer::new(&scene).unwrap();
    let opts = ReferenceOptions::default();
    let light = &scene.lights[0];
    for x in [
        DVec3::new(0.3, 0.1, 0.0),
        DVec3::new(1.5, -1.0, 0.0),
        DVec3::new(-3.0, 2.0, 0.0),
    ] {
        let est = pt.radiosity_at(0, false, x, DVec3::Z, 16, &opts).unwrap();
        let want = light.irradiance_at(x, DVec3::Z).map(|e| 0.6 * e);
        for c in 0..3 {
            // Nothing else to bounce off: every walk gives the same value.
            assert!(
                (est.mean[c] - want[c]).abs() <= 1e-12 * want[c].max(1.0),
                "{x}: {est:?} vs {want:?}"
            );
        }
        // And no indirect light at all.
        let ind = pt
            .indirect_irradiance_at(x, DVec3::Z, 16, 0, &opts)
            .unwrap();
        assert_eq!(ind.mean, [0.0; 3]);
    }
}

#[test]
fn indirect_only_estimate_in_the_furnace() {
    // E = 1, ρ = 0.5: irradiance H = E + ρH' ... total H = E/(1 − ρ) = 2, direct 1, so
    // the indirect irradiance is exactly 1.
    let scene = white_furnace(1.0, 0.5).unwrap();
    let pt = PathTracer::new(&scene).unwrap();
    let opts = ReferenceOptions::default();
    let est = pt
        .indirect_irradiance_at(DVec3::new(0.3, 0.6, 0.0), DVec3::Z, 20_000, 7, &opts)
        .unwrap();
    assert!(
        (est.mean[0] - 1.0).abs() < 4.0 * est.std_error[0] + 1e-3,
        "{est:?}"
    );
    assert!(est.std_error[0] < 0.02);
}

#[test]
fn meshless_field_direct_component_is_the_closed_form() {
    let scene = floor_scene();
    let surfaces = SceneSurfaces::new(&scene).unwrap();
    let cfg = MeshlessConfig {
        receiver_levels: 1,
        sender_levels: 1,
        r_coarse: Some(2.0),
        gather_rays: 4,
        viewpoint: Some([0.0, 0.0, 3.0]),
        skip_bounces: 0,
        ..Default::default()
    };
    let pre = Precomputed::build(&scene, &cfg, &|_, _, _| {}).unwrap();
    let rl = Relighter::new(&pre, CpuBackend).unwrap();
    let ind = rl.relight(&surfaces, &scene.lights).unwrap();
    // A lone floor reflects nothing back onto itself.
    assert!(ind.coeffs.iter().all(|v| *v == 0.0));
    let field = MeshlessField::new(
        &surfaces,
        IndirectSource::Hierarchical(&ind),
        DirectLighting::Lights(scene.lights.clone()),
        Component::Full,
    );
    let light = &scene.lights[0];
    let down = -DVec3::Z;
    for (x, y) in [(0.3, 0.1), (1.5, -1.0), (-3.0, 2.0), (4.0, 4.0)] {
        let ray = wavelux_geometry::Ray {
            origin: DVec3::new(x, y, 1.0),
            dir: down,
        };
        let hit = field.accel().closest_hit(&ray, 0.0, f64::INFINITY).unwrap();
        let p = field.resolve(&hit).unwrap();
        let want = light.irradiance_at(hit.point, DVec3::Z).map(|e| 0.6 * e);
        let got = field.radiosity(&p);
        for c in 0..3 {
            assert!(
                (got[c] - want[c]).abs() <= 1e-12 * want[c].max(1.0),
                "{x},{y}: {got:?} vs {want:?}"
            );
        }
    }
    // The renderer shows it (B/π per pixel): finite, lit under the spot.
    let view = View::look_at(DVec3::new(0.0, 0.0, 4.0), DVec3::ZERO, DVec3::Y, 0.8, 8, 8).unwrap();
    let opts = wavelux_render::RenderOptions {
        spp: 1,
        gather: 0,
        direct: 0,
        seed: 0,
    };
    let (img, _) = render(&field, &view, &opts, &|_| {}).unwrap();
    assert!(
        img.pixels
            .iter()
            .flatten()
            .all(|v| v.is_finite() && *v >= 0.0)
    );
    assert!(img.pixels.iter().any(|p| p[0] > 0.0));
    let ind_field = field.with_component(Component::Indirect);
    let hit = field
        .accel()
        .closest_hit(&view.ray(4.0, 4.0), 0.0, f64::INFINITY)
        .unwrap();
    let p = ind_field.resolve(&hit).unwrap();
    assert_eq!(ind_field.radiosity(&p), [0.0; 3]);
}
