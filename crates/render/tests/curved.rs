//! The Monte Carlo reference on curved, trimmed and complex surfaces against closed
//! forms: closed enclosures of any shape are white furnaces (`B = E/(1 − ρ)` at every
//! point, because every form-factor row sums to one), and a Lambertian sphere fully
//! above a plane's horizon irradiates a point of the plane with `E·R²·cos θ/d²`.

use glam::{DVec2, DVec3};
use wavelux_render::{PathTracer, ReferenceOptions, SurfaceEstimate};
use wavelux_scene::{
    AnalyticPatch, AnalyticSurface, BezierPatch, Loop, Material, Placement, PlaneFrame,
    PolygonShape, Rgb, Scene, Shape, Sidedness, Surface, builtin,
};

fn opts(seed: u64) -> ReferenceOptions {
    ReferenceOptions {
        seed,
        ..ReferenceOptions::default()
    }
}

fn placement(origin: DVec3) -> Placement {
    Placement {
        origin,
        axis: DVec3::Z,
        reference: DVec3::X,
    }
}

fn sphere(center: DVec3, radius: f64) -> Shape {
    Shape::Patch(AnalyticPatch {
        surface: AnalyticSurface::Sphere {
            placement: placement(center),
            radius,
            azimuth: (0.0, std::f64::consts::TAU),
            latitude: (-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2),
        },
        trim: None,
    })
}

fn assert_close(what: &str, est: &SurfaceEstimate, exact: f64) {
    for c in 0..3 {
        let z = (est.mean[c] - exact).abs() / est.std_error[c];
        assert!(
            z < 4.5,
            "{what}: {} ± {} vs {exact} (z = {z})",
            est.mean[c],
            est.std_error[c]
        );
        assert!(est.std_error[c] < 0.1 * exact, "{what}: too noisy");
    }
}

/// Furnace materials: a black front (seen from outside) and the furnace back.
fn furnace_materials(s: &mut Scene, e: f64, rho: f64) -> (usize, usize) {
    let black = s.add_material(Material::lambertian("black", Rgb::BLACK, Rgb::BLACK));
    let f = s.add_material(Material::lambertian(
        "furnace",
        Rgb::grey(rho),
        Rgb::grey(e),
    ));
    (black, f)
}

/// Inside a closed sphere (the interior is the back side of the outward-oriented
/// analytic patch), every point has `B = E/(1 − ρ)`.
#[test]
fn sphere_interior_furnace() {
    let (e, rho) = (1.0, 0.5);
    let exact = e / (1.0 - rho);
    let mut s = Scene::new("sphere-furnace");
    let (black, f) = furnace_materials(&mut s, e, rho);
    s.add_surface(Surface {
        name: "sphere".into(),
        shape: sphere(DVec3::new(0.2, -0.1, 0.3), 0.8),
        material: black,
        sides: Sidedness::TwoSided { back: f },
    });
    let pt = PathTracer::new(&s).unwrap();
    assert_close(
        "inner side average",
        &pt.side_average(0, true, 3000, &opts(1)).unwrap(),
        exact,
    );
    // The outside is black and sees nothing.
    assert_eq!(pt.surface_average(0, 50, &opts(1)).unwrap().mean, [0.0; 3]);
    // Per point, with the inward normal.
    for (k, dir) in [
        DVec3::Z,
        DVec3::new(1.0, -2.0, 0.5),
        DVec3::new(-0.3, 0.1, -1.0),
    ]
    .into_iter()
    .enumerate()
    {
        let n = dir.normalize();
        let x = DVec3::new(0.2, -0.1, 0.3) + 0.8 * n;
        let b = pt
            .radiosity_at(0, true, x, -n, 2000, &opts(10 + k as u64))
            .unwrap();
        assert_close(&format!("point {k}"), &b, exact);
    }
}

/// A closed can: a cylinder (inner = back side) and two disks (complex polygons with a
/// full-circle arc boundary) facing inwards, all emitting and reflecting.
#[test]
fn cylinder_with_disk_caps_furnace() {
    let (e, rho) = (2.0, 0.6);
    let exact = e / (1.0 - rho);
    let mut s = Scene::new("can-furnace");
    let (black, f) = furnace_materials(&mut s, e, rho);
    let r = 0.5;
    s.add_surface(Surface {
        name: "wall".into(),
        shape: Shape::Patch(AnalyticPatch {
            surface: AnalyticSurface::Cylinder {
                placement: placement(DVec3::ZERO),
                radius: r,
                azimuth: (0.0, std::f64::consts::TAU),
                height: (0.0, 1.2),
            },
            trim: None,
        }),
        material: black,
        sides: Sidedness::TwoSided { back: f },
    });
    for (name, z, u, v) in [
        ("bottom", 0.0, DVec3::X, DVec3::Y),
        ("top", 1.2, DVec3::Y, DVec3::X),
    ] {
        s.add_surface(Surface {
            name: name.into(),
            shape: Shape::Polygon(PolygonShape {
                frame: PlaneFrame::from_directions(DVec3::new(0.0, 0.0, z), u, v).unwrap(),
                outer: Loop::circle(DVec2::ZERO, r),
                holes: vec![],
            }),
            material: f,
            sides: Sidedness::OneSided,
        });
    }
    let pt = PathTracer::new(&s).unwrap();
    assert_close(
        "wall (inside)",
        &pt.side_average(0, true, 3000, &opts(2)).unwrap(),
        exact,
    );
    for k in [1, 2] {
        assert_close(
            &s.surfaces[k].name,
            &pt.surface_average(k, 3000, &opts(3)).unwrap(),
            exact,
        );
    }
}

/// The unit-cube furnace with its top face replaced by a bicubic Bézier patch with the
/// same (straight) boundary bulging outwards: still closed, still `E/(1 − ρ)` on every
/// face, including the curved emitter itself (sampled by Jacobian-bound rejection).
#[test]
fn furnace_with_a_bulged_bezier_face() {
    let (e, rho) = (1.0, 0.5);
    let exact = e / (1.0 - rho);
    let mut s = builtin::white_furnace(e, rho).unwrap();
    let top = s.surfaces.iter().position(|x| x.name == "face-z1").unwrap();
    // u along +y, v along +x: ∂u × ∂v points to −z (into the cube).
    let mut control = Vec::with_capacity(16);
    for i in 0..4 {
        for j in 0..4 {
            let interior = (1..=2).contains(&i) && (1..=2).contains(&j);
            control.push(DVec3::new(
                j as f64 / 3.0,
                i as f64 / 3.0,
                if interior { 1.45 } else { 1.0 },
            ));
        }
    }
    s.surfaces[top].shape = Shape::Bezier(BezierPatch {
        degree_u: 3,
        degree_v: 3,
        control,
    });
    let pt = PathTracer::new(&s).unwrap();
    for k in 0..s.surfaces.len() {
        assert_close(
            &s.surfaces[k].name,
            &pt.surface_average(k, 2500, &opts(4)).unwrap(),
            exact,
        );
    }
}

/// A black Lambertian sphere of exitance `E` and radius `R` centred at height `h` above
/// a large receiving plane (`ρ`, black otherwise): at a point at horizontal offset `q`,
/// `d² = h² + q²`, `cos θ = h/d`, and `B = ρ·E·R²·cos θ/d²` exactly (the sphere is
/// above the horizon; nothing else is lit).
#[test]
fn plane_under_a_spherical_emitter() {
    let (e, rho, radius, h) = (3.0, 0.7, 0.3, 1.0);
    let mut s = Scene::new("sphere-lamp");
    let recv = s.add_material(Material::lambertian("recv", Rgb::grey(rho), Rgb::BLACK));
    let lamp = s.add_material(Material::lambertian("lamp", Rgb::BLACK, Rgb::grey(e)));
    s.add_surface(Surface {
        name: "floor".into(),
        shape: Shape::parallelogram(DVec3::new(-3.0, -3.0, 0.0), DVec3::X * 6.0, DVec3::Y * 6.0),
        material: recv,
        sides: Sidedness::OneSided,
    });
    s.add_surface(Surface {
        name: "lamp".into(),
        shape: sphere(DVec3::new(0.0, 0.0, h), radius),
        material: lamp,
        sides: Sidedness::OneSided,
    });
    let pt = PathTracer::new(&s).unwrap();
    for (k, (x, y)) in [(0.0, 0.0), (0.5, 0.3), (1.2, -0.4)]
        .into_iter()
        .enumerate()
    {
        let d2 = h * h + x * x + y * y;
        let exact = rho * e * radius * radius * (h / d2.sqrt()) / d2;
        let b = pt
            .radiosity_at(
                0,
                false,
                DVec3::new(x, y, 0.0),
                DVec3::Z,
                4000,
                &opts(20 + k as u64),
            )
            .unwrap();
        assert_close(&format!("floor point ({x}, {y})"), &b, exact);
    }
    // The lamp itself: B = E exactly (ρ = 0).
    assert_eq!(pt.surface_average(1, 100, &opts(1)).unwrap().mean, [e; 3]);
}

/// A sphere lamp over an annulus (a masked virtual support) solved by the wavelet
/// solver: the real-area average of the floor (`side_average`) matches the closed
/// form `ρ E R² · 2h [1/√(h²+a₁²) − 1/√(h²+a₂²)] / (a₂² − a₁²)` within the accuracy the
/// solver states, and an image of the solution (curved and masked supports in the
/// field's accelerator, light sampling of the curved emitter in the final gather)
/// matches the path tracer's image. The solve is the target loop at `T` for the scene
/// and every face side (`solve_to_target`: the floor's estimated relative L1 error
/// `∫|B − B̂| / ∫B` is `≤ T`); the floor's mean is off by at most its L1 error, so
/// `|B̄ − B̄_exact| ≤ T · B̄_exact`.
#[test]
fn solved_sphere_lamp_over_an_annulus() {
    use wavelux_render::{RenderOptions, SolutionField, View, render, side_average};
    use wavelux_solver::{Side, TargetConfig, solve_to_target};
    const T: f64 = 0.02;
    let (e, rho, radius, h, a1, a2) = (5.0, 0.8, 0.25, 0.6, 0.2, 1.0);
    let mut s = Scene::new("lamp");
    let recv = s.add_material(Material::lambertian("recv", Rgb::grey(rho), Rgb::BLACK));
    let lamp = s.add_material(Material::lambertian("lamp", Rgb::BLACK, Rgb::grey(e)));
    s.add_surface(Surface {
        name: "floor".into(),
        shape: Shape::Polygon(PolygonShape {
            frame: PlaneFrame::from_directions(DVec3::ZERO, DVec3::X, DVec3::Y).unwrap(),
            outer: Loop::circle(DVec2::ZERO, a2),
            holes: vec![Loop::circle(DVec2::ZERO, a1)],
        }),
        material: recv,
        sides: Sidedness::OneSided,
    });
    s.add_surface(Surface {
        name: "lamp".into(),
        shape: sphere(DVec3::new(0.0, 0.0, h), radius),
        material: lamp,
        sides: Sidedness::OneSided,
    });
    let exact = rho
        * e
        * radius
        * radius
        * 2.0
        * h
        * (1.0 / (h * h + a1 * a1).sqrt() - 1.0 / (h * h + a2 * a2).sqrt())
        / (a2 * a2 - a1 * a1);
    let out = solve_to_target(
        &s,
        &TargetConfig {
            target: T,
            face_target: Some(T),
            ..TargetConfig::default()
        },
    )
    .unwrap();
    assert!(out.reached, "{}", out.stop_reason);
    let sol = out.solution;
    let b = side_average(&sol, 0, Side::Front).unwrap();
    let field = SolutionField::new(&sol).unwrap();
    let view = View::look_at(
        DVec3::new(0.0, -2.0, 1.5),
        DVec3::new(0.0, 0.0, 0.2),
        DVec3::Z,
        0.9,
        24,
        24,
    )
    .unwrap();
    let (img, _) = render(
        &field,
        &view,
        &RenderOptions {
            spp: 8,
            gather: 16,
            direct: 0,
            seed: 3,
        },
        &|_| {},
    )
    .unwrap();
    let pt = PathTracer::new(&s).unwrap();
    let refimg = pt.render(&view, 16, &opts(3), &|_| {}).unwrap();
    let m = img.metrics(&refimg).unwrap();
    assert!((b[0] - exact).abs() <= T * exact, "{} vs {exact}", b[0]);
    assert!(m.relative_l1 < 0.06, "{m:?}");
}
