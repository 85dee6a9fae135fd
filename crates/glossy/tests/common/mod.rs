//! Small scenes shared by the glossy tests.
#![allow(dead_code)]

use glam::DVec3;
use wavelux_scene::{Material, Rgb, Scene, Shape, Sidedness, Surface, WardParams};

/// Adds a one-sided parallelogram with a material.
pub fn quad(scene: &mut Scene, name: &str, origin: DVec3, eu: DVec3, ev: DVec3, mat: Material) {
    let m = scene.add_material(mat);
    scene.add_surface(Surface {
        name: name.into(),
        shape: Shape::Parallelogram {
            origin,
            edge_u: eu,
            edge_v: ev,
        },
        material: m,
        sides: Sidedness::OneSided,
    });
}

/// A square of side `a` centred at `c` with unit normal `n` (one of ±x, ±y, ±z).
pub fn square(scene: &mut Scene, name: &str, c: DVec3, n: DVec3, a: f64, mat: Material) {
    let t = if n.x.abs() > 0.5 { DVec3::Y } else { DVec3::X };
    let b = n.cross(t);
    // edge_u × edge_v = t × b = n.
    quad(scene, name, c - 0.5 * a * (t + b), a * t, a * b, mat);
}

pub fn ward(name: &str, rho_d: f64, rho_s: f64, alpha: f64) -> Material {
    let mut m = Material::lambertian(name, Rgb::grey(rho_d), Rgb::BLACK);
    m.ward = Some(WardParams {
        specular: Rgb::grey(rho_s),
        alpha_x: alpha,
        alpha_y: alpha,
    });
    m
}

/// Glossy Fig. 12's three patches: 1 (0.01², emitter facing down at (−0.5, 0, 1)), 2
/// (0.01² at the origin facing up, Ward α = 0.2), 3 (2 × 2 diffuse facing down,
/// centred (0.75, 0, 1.5)).
pub fn three_patches(emission: f64, rho_d2: f64, rho_s2: f64, rho3: f64) -> Scene {
    let mut s = Scene::new("three-patches");
    square(
        &mut s,
        "patch1",
        DVec3::new(-0.5, 0.0, 1.0),
        -DVec3::Z,
        0.01,
        Material::lambertian("light", Rgb::BLACK, Rgb::grey(emission)),
    );
    square(
        &mut s,
        "patch2",
        DVec3::ZERO,
        DVec3::Z,
        0.01,
        ward("glossy", rho_d2, rho_s2, 0.2),
    );
    square(
        &mut s,
        "patch3",
        DVec3::new(0.75, 0.0, 1.5),
        -DVec3::Z,
        2.0,
        Material::lambertian("diffuse", Rgb::grey(rho3), Rgb::BLACK),
    );
    s
}

/// A closed cube `[-1, 1]³` of inward-facing black emitters of radiance `l` (exitance
/// `π l`) around a small square patch of side `a` facing `+z` at the origin.
pub fn furnace(l: f64, patch: Material, a: f64) -> Scene {
    let mut s = Scene::new("furnace");
    let e = Material::lambertian("wall", Rgb::BLACK, Rgb::grey(std::f64::consts::PI * l));
    for (i, n) in [
        DVec3::X,
        -DVec3::X,
        DVec3::Y,
        -DVec3::Y,
        DVec3::Z,
        -DVec3::Z,
    ]
    .into_iter()
    .enumerate()
    {
        square(&mut s, &format!("wall{i}"), -n, n, 2.0, e.clone());
    }
    square(&mut s, "patch", DVec3::ZERO, DVec3::Z, a, patch);
    s
}
