//! The glossy path tracer against closed forms (white furnace with every Ward variant,
//! cosine-power emitters), against the diffuse path tracer in the diffuse limit, and
//! its determinism across thread counts.

use glam::{DVec2, DVec3};
use wavelux_glossy::{GlossyScene, ImportanceSource, WardLobe, WardVariant};
use wavelux_render::{GlossyTracer, PathTracer, ReferenceOptions};
use wavelux_scene::{
    EmissionProfile, Material, Rgb, Scene, Shape, Sidedness, Surface, WardParams, builtin,
};
use wavelux_support::Side;

fn opts(seed: u64) -> ReferenceOptions {
    ReferenceOptions {
        seed,
        ..ReferenceOptions::default()
    }
}

/// A one-sided square of side `a` centred at `c` with unit normal `n` (±x, ±y, ±z).
fn square(scene: &mut Scene, name: &str, c: DVec3, n: DVec3, a: f64, mat: Material) {
    let m = scene.add_material(mat);
    let t = if n.x.abs() > 0.5 { DVec3::Y } else { DVec3::X };
    let b = n.cross(t);
    scene.add_surface(Surface {
        name: name.into(),
        shape: Shape::parallelogram(c - 0.5 * a * (t + b), a * t, a * b),
        material: m,
        sides: Sidedness::OneSided,
    });
}

fn ward(rho_d: f64, rho_s: f64, ax: f64, ay: f64) -> Material {
    let mut m = Material::lambertian("ward", Rgb::grey(rho_d), Rgb::BLACK);
    m.ward = Some(WardParams {
        specular: Rgb::grey(rho_s),
        alpha_x: ax,
        alpha_y: ay,
    });
    m
}

fn patch_index(gs: &GlossyScene, name: &str) -> usize {
    gs.patches
        .iter()
        .position(|p| p.name.starts_with(name))
        .unwrap()
}

#[test]
fn furnace_radiance_is_rho_d_plus_rho_s_times_the_albedo() {
    // A small Ward patch in a closed cube of black emitters of unit radiance reflects
    // L(ω_o) = ρ_d + ρ_s a(θ_o) (a: the lobe's directional albedo, symmetric f).
    // 4σ per estimate (36 estimates per variant), plus the albedo quadrature's 1e-3.
    let (rho_d, rho_s) = (0.3, 0.6);
    for variant in WardVariant::ALL {
        for alpha in [0.01, 0.2, 0.5] {
            let mut s = Scene::new("furnace");
            let wall = Material::lambertian("wall", Rgb::BLACK, Rgb::grey(std::f64::consts::PI));
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
                square(&mut s, &format!("wall{i}"), -n, n, 2.0, wall.clone());
            }
            square(
                &mut s,
                "patch",
                DVec3::ZERO,
                DVec3::Z,
                0.1,
                ward(rho_d, rho_s, alpha, alpha),
            );
            let gs = GlossyScene::new(&s, "furnace", variant, &ImportanceSource::Off).unwrap();
            let tracer = GlossyTracer::new(&gs);
            let p = patch_index(&gs, "patch");
            let lobe = WardLobe::new(variant, alpha, alpha).unwrap();
            for (k, deg) in [0.0f64, 45.0, 80.0, 89.0].into_iter().enumerate() {
                let th = deg.to_radians();
                let w = DVec3::new(th.sin() * 0.6, th.sin() * 0.8, th.cos());
                let exact = rho_d + rho_s * lobe.albedo_at(th).unwrap();
                let est = tracer
                    .radiance_at(p, DVec2::splat(0.5), w, 4000, k as u64, &opts(1))
                    .unwrap();
                let (m, se) = (est.mean[0], est.std_error[0]);
                assert!(
                    (m - exact).abs() <= 4.0 * se + 1e-3 * exact,
                    "{variant:?} α = {alpha} θ = {deg}°: {m} ± {se} vs {exact}"
                );
                assert!(
                    se < 0.05 * exact,
                    "{variant:?} α = {alpha} θ = {deg}°: σ = {se}"
                );
            }
        }
    }
}

#[test]
fn cosine_power_emitter_lights_a_small_receiver_by_its_closed_form() {
    // A small emitter (side 0.02, exitance E, exponent n) at height 1 facing down and a
    // small Lambertian receiver at (x, 0, 0) facing up: H = E (n+2)/(2π) cosⁿθ · A cos²θ
    // / r² with cos θ = 1/r, and L = ρ H / π (relative error of the point-source
    // approximation ~1e-4).
    let (e, n, rho, a) = (50.0, 8.0, 0.5, 0.02);
    let mut s = Scene::new("spot");
    let mut light = Material::lambertian("light", Rgb::BLACK, Rgb::grey(e));
    light.emission_profile = EmissionProfile::CosinePower { exponent: n };
    square(&mut s, "light", DVec3::Z, -DVec3::Z, a, light);
    for (i, x) in [0.0, 0.5, 1.0].into_iter().enumerate() {
        square(
            &mut s,
            &format!("recv{i}"),
            DVec3::new(x, 0.0, 0.0),
            DVec3::Z,
            0.01,
            Material::lambertian("recv", Rgb::grey(rho), Rgb::BLACK),
        );
    }
    let gs = GlossyScene::new(&s, "spot", WardVariant::Bounded, &ImportanceSource::Off).unwrap();
    let tracer = GlossyTracer::new(&gs);
    for (i, x) in [0.0f64, 0.5, 1.0].into_iter().enumerate() {
        let r = (1.0 + x * x).sqrt();
        let c = 1.0 / r;
        let h = e * (n + 2.0) / std::f64::consts::TAU * c.powf(n) * a * a * c * c / (r * r);
        let exact = rho * h / std::f64::consts::PI;
        let p = patch_index(&gs, &format!("recv{i}"));
        let est = tracer
            .radiance_at(
                p,
                DVec2::splat(0.5),
                DVec3::new(0.3, 0.1, 1.0),
                400,
                7,
                &opts(2),
            )
            .unwrap();
        let got = est.mean[1];
        assert!(
            (got - exact).abs() <= 4.0 * est.std_error[1] + 2e-3 * exact,
            "x = {x}: {got} ± {} vs {exact}",
            est.std_error[1]
        );
    }
}

#[test]
fn diffuse_limit_agrees_with_the_diffuse_path_tracer() {
    // Without Ward lobes both tracers estimate the same radiosity equation: the mean
    // exitance of every Cornell-box side agrees within 4 combined standard errors.
    let scene = builtin::cornell_box();
    let gs = GlossyScene::new(
        &scene,
        "cornell",
        WardVariant::Bounded,
        &ImportanceSource::Off,
    )
    .unwrap();
    let glossy = GlossyTracer::new(&gs);
    let diffuse = PathTracer::new(&scene).unwrap();
    for s in 0..scene.surfaces.len() {
        let a = glossy
            .side_exitance(s, Side::Front, 3000, &opts(4))
            .unwrap();
        let b = diffuse.surface_average(s, 3000, &opts(5)).unwrap();
        for c in 0..3 {
            let sig = a.std_error[c].hypot(b.std_error[c]);
            assert!(
                (a.mean[c] - b.mean[c]).abs() <= 4.0 * sig + 1e-12,
                "surface {s} channel {c}: glossy {} ± {} vs diffuse {} ± {}",
                a.mean[c],
                a.std_error[c],
                b.mean[c],
                b.std_error[c]
            );
        }
    }
}

#[test]
fn estimates_do_not_depend_on_the_thread_count() {
    let mut scene = builtin::cornell_box();
    for m in &mut scene.materials {
        if m.emission.0 == [0.0; 3] {
            m.ward = Some(WardParams {
                specular: Rgb::grey(0.2),
                alpha_x: 0.2,
                alpha_y: 0.1,
            });
        }
    }
    let gs = GlossyScene::new(
        &scene,
        "cornell",
        WardVariant::Bounded,
        &ImportanceSource::Off,
    )
    .unwrap();
    let tracer = GlossyTracer::new(&gs);
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| tracer.side_exitance(0, Side::Front, 700, &opts(3)).unwrap())
    };
    assert_eq!(run(1), run(3));
}

#[test]
fn glossy_solver_lights_receivers_under_a_spotlight_like_the_tracer() {
    // A cosine-power spotlight (exponent 4, side 0.1, height 1) over a diffuse and a
    // Ward receiver (0.2 wide) beside the lobe's axis. Before the oracle reached the
    // lobe's fine wavelets the solver left such receivers 68–83 % dark at any depth.
    let mut s = Scene::new("spot");
    let mut light = Material::lambertian("light", Rgb::BLACK, Rgb::grey(50.0));
    light.emission_profile = EmissionProfile::CosinePower { exponent: 4.0 };
    square(&mut s, "light", DVec3::Z, -DVec3::Z, 0.1, light);
    square(
        &mut s,
        "diffuse",
        DVec3::new(0.15, 0.0, 0.0),
        DVec3::Z,
        0.2,
        Material::lambertian("recv", Rgb::grey(0.5), Rgb::BLACK),
    );
    square(
        &mut s,
        "ward",
        DVec3::new(-0.4, 0.1, 0.0),
        DVec3::Z,
        0.2,
        ward(0.3, 0.4, 0.2, 0.2),
    );
    let mut sol = wavelux_glossy::GlossySolution::new(
        &s,
        "spot",
        wavelux_glossy::GlossyConfig {
            rounds: 5,
            ..wavelux_glossy::GlossyConfig::default()
        },
    )
    .unwrap();
    let v0 = [1, 2].map(|k| sol.side_exitance(k, Side::Front).unwrap()[0]);
    sol.run(|_| {}).unwrap();
    let tracer = GlossyTracer::new(&sol.scene);
    for (i, k) in [1, 2].into_iter().enumerate() {
        let got = sol.side_exitance(k, Side::Front).unwrap()[0];
        let r = tracer
            .side_exitance(k, Side::Front, 20_000, &opts(11))
            .unwrap();
        let (rel, rel0) = (got / r.mean[0] - 1.0, v0[i] / r.mean[0] - 1.0);
        // Measured with the default (cosine) map: V⁰ −65 % / −54 %, five rounds
        // −18 % / +6 %; with the paper's map V⁰ −82 % / −83 %, five rounds −12 % / −19 %
        // (the level-4 lobe projection and 2 × 2 transport points; tracer noise < 1 %).
        assert!(rel0 < -0.5, "surface {k}: V⁰ {rel0}");
        assert!(
            rel.abs() < 0.25,
            "surface {k}: {got} vs {} ± {}",
            r.mean[0],
            r.std_error[0]
        );
    }
}
