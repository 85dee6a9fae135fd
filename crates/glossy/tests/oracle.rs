//! The refinement oracle (Glossy §5.3) where it is easy to starve: a cosine-power
//! spotlight decomposed up front (§6.3) lights small receivers as the point-source
//! closed form says once refinement reaches the fine emitted wavelets that carry its
//! lobe (the glossy path tracer agrees with the same closed form: wavelux-render's
//! `glossy_tracer` tests); importance emitted by a patch refines the links into it
//! (§7.1).

mod common;

use glam::{DVec2, DVec3};
use wavelux_glossy::directions::{CellRule, integrate_cell};
use wavelux_glossy::solution::Field;
use wavelux_glossy::ward::cosine_power_radiance;
use wavelux_glossy::*;
use wavelux_scene::{EmissionProfile, Material, Rgb, Scene};
use wavelux_support::Side;

const E: f64 = 50.0;
const N: f64 = 4.0;
const A: f64 = 0.02;
const RHO: f64 = 0.5;
const XS: [f64; 3] = [0.0, 0.3, 0.6];

/// A small spotlight (side `A`, exitance `E`, exponent `N`) at height 1 facing down
/// and small Lambertian receivers (side 0.01, reflectance `RHO`) at `(x, 0, 0)`.
fn spot() -> Scene {
    let mut s = Scene::new("spot");
    let mut light = Material::lambertian("light", Rgb::BLACK, Rgb::grey(E));
    light.emission_profile = EmissionProfile::CosinePower { exponent: N };
    common::square(&mut s, "light", DVec3::Z, -DVec3::Z, A, light);
    for (i, &x) in XS.iter().enumerate() {
        common::square(
            &mut s,
            &format!("recv{i}"),
            DVec3::new(x, 0.0, 0.0),
            DVec3::Z,
            0.01,
            Material::lambertian("recv", Rgb::grey(RHO), Rgb::BLACK),
        );
    }
    s
}

/// Point-source exitance of a receiver at `(x, 0, 0)`: `ρ E (n+2)/(2π) cosⁿθ A cos²θ/r²`.
fn closed_form(x: f64) -> f64 {
    let r = (1.0 + x * x).sqrt();
    let c = 1.0 / r;
    RHO * cosine_power_radiance(E, N, c) * A * A * c * c / (r * r)
}

/// The same exitance with the lobe replaced by its level-`level` projection (the
/// average of the profile over the direction cell that holds `ω_xy`, parameter
/// measure), integrated over both patches by 8 × 8 midpoints each: what the solver
/// converges to at that emitter level.
fn projected(sol: &GlossySolution, recv: usize, level: u8) -> f64 {
    let rule = CellRule::new(16).unwrap();
    let dirs = sol.config.directions;
    let light = &sol.scene.patches[0];
    let frame = light.frame(0.5, 0.5);
    let r = &sol.scene.patches[recv];
    let cells = 1u16 << level;
    let mut cache = std::collections::HashMap::new();
    let mut avg = |i: [u16; 2]| {
        *cache.entry(i).or_insert_with(|| {
            let g = |u: DVec2| cosine_power_radiance(E, N, dirs.direction(u).z);
            integrate_cell(&rule, level, i, g) * f64::from(cells).powi(2)
        })
    };
    let k = 8;
    let mid = |i: usize| (i as f64 + 0.5) / k as f64;
    let mut s = 0.0;
    for a in 0..k * k {
        let x = light.support.point(mid(a % k), mid(a / k));
        for b in 0..k * k {
            let y = r.support.point(mid(b % k), mid(b / k));
            let d = y - x;
            let r2 = d.length_squared();
            let w = d / r2.sqrt();
            let u = dirs.inverse(frame.to_local(w)).unwrap();
            let i = u
                .to_array()
                .map(|v| ((v * f64::from(cells)) as u16).min(cells - 1));
            let g = (-w.dot(light.support.normal_at(0.5, 0.5)))
                * w.dot(r.support.normal_at(0.5, 0.5))
                / r2;
            s += avg(i) * g;
        }
    }
    RHO * s * light.support.area / (k * k * k * k) as f64
}

/// One map's run: the `V⁰` receivers darker than `dark` (relative), then after 5
/// rounds within `to_model` of the level-`emitter_level` projection in that map.
fn spotlight_case(directions: DirectionKind, dark: f64, to_model_bound: f64) {
    let scene = spot();
    let cfg = GlossyConfig {
        rounds: 0,
        directions,
        ..GlossyConfig::default()
    };
    let mut sol = GlossySolution::new(&scene, "spot", cfg.clone()).unwrap();
    let rel = |sol: &GlossySolution, reference: &dyn Fn(usize) -> f64| {
        (0..XS.len())
            .map(|i| sol.side_exitance(i + 1, Side::Front).unwrap()[0] / reference(i) - 1.0)
            .collect::<Vec<_>>()
    };
    let start = rel(&sol, &|i| closed_form(XS[i]));
    assert!(start.iter().all(|e| *e < dark), "{directions:?}: {start:?}");
    for _ in 0..5 {
        sol.refine_round().unwrap();
    }
    let level = cfg.emitter_level;
    let model: Vec<f64> = (1..=XS.len()).map(|i| projected(&sol, i, level)).collect();
    let to_model = rel(&sol, &|i| model[i]);
    let to_exact = rel(&sol, &|i| closed_form(XS[i]));
    assert!(
        to_model.iter().all(|e| e.abs() < to_model_bound),
        "{directions:?}: {to_model:?}"
    );
    // Against the exact lobe, plus the level-4 projection's own error (up to 20 % at
    // 31° where cos⁴ falls steeply across a 1/16 cell).
    for (i, e) in to_exact.iter().enumerate() {
        let proj = model[i] / closed_form(XS[i]) - 1.0;
        assert!(
            (e - proj).abs() < 0.12,
            "{directions:?} {i}: {e} (projection alone {proj})"
        );
    }
}

#[test]
fn spotlight_reaches_receivers_through_its_fine_wavelets() {
    // V⁰ carries only the lobe's mean. The lobe sits centred in the direction square,
    // so the level-0 angular wavelets of the emitter vanish by symmetry; refinement
    // must still reach the finer ones.
    // The paper's map: V⁰ receivers 68–83 % dark; against the projected lobe, the
    // quadrature error of the default options' 2 × 2 points per child cell on the
    // direction cells' edges (measured +10 %, +6 %, +8 %; +5 %, +3.5 %, +4.3 % with
    // 4 × 4 points).
    spotlight_case(DirectionKind::Glossy, -0.6, 0.12);
    // The cosine map (the default): V⁰ receivers 67 / 60 / 38 % dark; against its own
    // projected lobe measured −1.3 %, −2e-6, −3e-7 (against the exact lobe −2.8 %,
    // −3.5 %, −13.6 %, the last the level-4 projection's own error).
    spotlight_case(DirectionKind::Cosine, -0.3, 0.03);
}

#[test]
fn importance_emitted_by_a_patch_refines_the_links_into_it() {
    // Glossy §7.1: without importance, refinement spends every link between patches 1
    // and 2 (patch 3 keeps its V⁰ link); with importance emitted by patch 3 the
    // interactions at patch 3 are refined and its radiance gets closer to the
    // reference L₃ = (ρ₃/π) L₂ G A₂.
    let scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    let run = |importance: ImportanceSource| {
        let mut sol = GlossySolution::new(
            &scene,
            "three",
            GlossyConfig {
                variant: WardVariant::Original,
                rounds: 3,
                importance,
                ..GlossyConfig::default()
            },
        )
        .unwrap();
        sol.run(|_| {}).unwrap();
        sol
    };
    let none = run(ImportanceSource::Off);
    let imp = run(ImportanceSource::Surfaces(vec!["patch3".into()]));
    let into_3 = |s: &GlossySolution| s.links.ranges[2].len();
    assert_eq!(into_3(&none), 1);
    assert!(into_3(&imp) > 1, "{}", into_3(&imp));
    // Patch 3's radiance against the point-patch reference over a grid of its points.
    let lobe = WardLobe::new(WardVariant::Original, 0.2, 0.2).unwrap();
    let x1 = DVec3::new(-0.5, 0.0, 1.0);
    let l2 = |w: DVec3| {
        let r2 = x1.length_squared();
        let dir = -x1 / r2.sqrt();
        0.5 * lobe.eval(-dir, w) * dir.z * dir.z / r2 * 1e-4
    };
    let err = |sol: &GlossySolution| {
        let support = &sol.scene.patches[2].support;
        let (mut e, mut n) = (0.0, 0.0);
        for i in 0..8 {
            for j in 0..8 {
                let st = DVec2::new((f64::from(i) + 0.5) / 8.0, (f64::from(j) + 0.5) / 8.0);
                let z = support.point(st.x, st.y);
                let d = z.length();
                let w = z / d;
                let r = 0.5 / std::f64::consts::PI * l2(w) * w.z * w.z / (d * d) * 1e-4;
                e += (sol.radiance(2, st, -DVec3::Z)[0] - r).powi(2);
                n += r * r;
            }
        }
        (e / n).sqrt()
    };
    let (e_none, e_imp) = (err(&none), err(&imp));
    assert!(e_imp < 0.97 * e_none, "{e_imp} vs {e_none}");
}

/// `M = ∫_{patch 3} ∫_{patch 2} L₂(y → z) G(y, z) dA_y dA_z` for the three patches
/// with patch 2 of side `a2`: the power arriving at patch 3 (its `Γ_e = 1`), with
/// `L₂(y → z) = ρ_s k(ω_{y1}, ω_{yz}) L_e A₁ cos θ_y cos θ₁ / r²` from the 0.01² light
/// taken as a point (relative error ~1e-4), by 16 × 16 Gauss points on patches 2 and 3.
fn three_patch_measure(a2: f64) -> f64 {
    let lobe = WardLobe::new(WardVariant::Original, 0.2, 0.2).unwrap();
    let (u, w) = wavelux_quadrature::GaussLegendre::new(16).unwrap().unit();
    let x1 = DVec3::new(-0.5, 0.0, 1.0);
    let mut m = 0.0;
    for (i, j) in (0..16).flat_map(|i| (0..16).map(move |j| (i, j))) {
        let y = DVec3::new(a2 * (u[i] - 0.5), a2 * (u[j] - 0.5), 0.0);
        let d1 = x1 - y;
        let r1 = d1.length();
        let w1 = d1 / r1;
        let e = 1e-4 * w1.z * w1.z / (r1 * r1) * w[i] * w[j] * a2 * a2;
        for (k, l) in (0..16).flat_map(|k| (0..16).map(move |l| (k, l))) {
            let z = DVec3::new(0.75 + 2.0 * (u[k] - 0.5), 2.0 * (u[l] - 0.5), 1.5);
            let d = z - y;
            let r = d.length();
            let wo = d / r;
            m += e * 4.0 * w[k] * w[l] * 0.5 * lobe.eval(w1, wo) * wo.z * wo.z / (r * r);
        }
    }
    m
}

#[test]
fn importance_refines_into_small_receivers_whatever_their_size() {
    // Glossy §4.2: the eye's measure `M(Γ_e, L)` equals the importance arriving at
    // the light, `M(Γ, L_e)`. The second needs the importance links into patch 2
    // refined, whose oracle value `|Γ_s|·est·R_r` needs the radiance arriving at patch
    // 2 from the 0.01² light; directional rays alone never hit it, and `M(Γ, L_e)`
    // stayed at its V⁰ value (−83 %) at every size of patch 2.
    for a2 in [1e-3, 1e-2, 1e-1, 1.0] {
        let mut scene = Scene::new("three");
        common::square(
            &mut scene,
            "patch1",
            DVec3::new(-0.5, 0.0, 1.0),
            -DVec3::Z,
            0.01,
            Material::lambertian("light", Rgb::BLACK, Rgb::grey(std::f64::consts::PI)),
        );
        let glossy = common::ward("glossy", 0.0, 0.5, 0.2);
        common::square(&mut scene, "patch2", DVec3::ZERO, DVec3::Z, a2, glossy);
        common::square(
            &mut scene,
            "patch3",
            DVec3::new(0.75, 0.0, 1.5),
            -DVec3::Z,
            2.0,
            Material::lambertian("diffuse", Rgb::grey(0.5), Rgb::BLACK),
        );
        let cfg = GlossyConfig {
            variant: WardVariant::Original,
            rounds: 5,
            importance: ImportanceSource::Surfaces(vec!["patch3".into()]),
            ..GlossyConfig::default()
        };
        let mut sol = GlossySolution::new(&scene, "three", cfg).unwrap();
        let reference = three_patch_measure(a2);
        let errors = |sol: &GlossySolution| {
            let eye = sol.pairing(Field::EmittedImportance, Field::Radiance, 8);
            let light = sol.pairing(Field::Importance, Field::EmittedRadiance, 8);
            [
                eye.unwrap()[0] / reference - 1.0,
                light.unwrap()[0] / reference - 1.0,
            ]
        };
        let start = errors(&sol);
        sol.run(|_| {}).unwrap();
        let end = errors(&sol);
        // Measured: V⁰ −74..−84 % for both; after five rounds −14..−19 % (eye) and
        // −14..+1 % (light) at every size.
        for (e0, e) in start.iter().zip(&end) {
            assert!(
                e.abs() < 0.25 && e.abs() < e0.abs() / 3.0,
                "{a2}: {start:?} -> {end:?}"
            );
        }
    }
}
