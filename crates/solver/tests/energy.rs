//! Energy balance against an independent measurement of the escaped power.
//!
//! `Energy::escaped` is measured by rays from the geometry (`wavelux_solver::escape`),
//! `absorbed` and `unshot` come from the discrete operator: `imbalance = emitted −
//! absorbed − unshot − escaped` is the operator's row-sum error plus the ray estimate's
//! noise, so these tests can fail. The ray estimate itself is checked against exact
//! form factors.

use glam::DVec3;
use wavelux_geometry::formfactor::area_form_factor;
use wavelux_scene::builtin::white_furnace;
use wavelux_scene::{Material, Rgb, Scene, Shape, Sidedness, Surface};
use wavelux_solver::shoot::{ShootConfig, shoot};
use wavelux_solver::{BasisKind, LinearMethod, Solution, SolverConfig, solve};

/// An emitting square (E = 1, facing −z) at height `d` over a receiving unit square
/// (facing +z) whose reflectance is negligible: the escaped power is
/// `E·A·(1 − F_12)` up to `ρ`.
fn facing_squares(d: f64, rho: f64) -> (Scene, f64) {
    let mut s = Scene::new("facing squares");
    let light = s.add_material(Material::lambertian("light", Rgb::BLACK, Rgb::grey(1.0)));
    let recv = s.add_material(Material::lambertian("recv", Rgb::grey(rho), Rgb::BLACK));
    let top = [
        DVec3::new(0.0, 0.0, d),
        DVec3::new(0.0, 1.0, d),
        DVec3::new(1.0, 1.0, d),
        DVec3::new(1.0, 0.0, d),
    ];
    let bottom = [DVec3::ZERO, DVec3::X, DVec3::X + DVec3::Y, DVec3::Y];
    s.add_surface(Surface {
        name: "light".into(),
        shape: Shape::parallelogram(top[0], DVec3::Y, DVec3::X),
        material: light,
        sides: Sidedness::OneSided,
    });
    s.add_surface(Surface {
        name: "receiver".into(),
        shape: Shape::parallelogram(DVec3::ZERO, DVec3::X, DVec3::Y),
        material: recv,
        sides: Sidedness::OneSided,
    });
    let f12 = area_form_factor(&top, &bottom).unwrap();
    (s, f12)
}

fn deepest_level(sol: &Solution) -> u8 {
    sol.system()
        .hierarchy()
        .keys()
        .iter()
        .map(|k| k.level)
        .max()
        .unwrap_or(0)
}

/// The ray estimate agrees with the exact escaped power `E·A·(1 − F_12)` within four
/// standard errors (plus the receiver's reflected power, `ρ = 1e-9`), for gathering
/// and shooting, at two distances.
#[test]
fn escaped_power_matches_exact_form_factors() {
    for d in [0.25, 1.0] {
        let (scene, f12) = facing_squares(d, 1e-9);
        let exact = 1.0 - f12;
        let gather = solve(
            &scene,
            &SolverConfig {
                eps: 1e-3,
                max_level: 3,
                ..SolverConfig::default()
            },
        )
        .unwrap();
        let shot = shoot(
            &scene,
            &ShootConfig {
                max_level: 3,
                ..ShootConfig::default()
            },
        )
        .unwrap();
        for (name, sol) in [("gather", &gather), ("shoot", &shot)] {
            let e = sol.energy;
            let (got, se) = (e.escaped[0], e.escaped_std_error[0]);
            println!("d {d} {name}: escaped {got:.5} ± {se:.1e}, exact {exact:.5}");
            assert!(se > 0.0 && se < 1.5e-2 * exact, "{name}: σ {se}");
            assert!(
                (got - exact).abs() <= 4.0 * se + 1e-6,
                "{name} d {d}: escaped {got} vs exact {exact} (σ {se})"
            );
        }
    }
}

/// The operator's own count of the power it delivers nowhere matches the exact value:
/// the transfer blocks' error on a smooth, separated pair (3×3 Gauss points per axis,
/// distance ≥ side/4) is below 1 % of the transported power.
#[test]
fn operator_loss_matches_exact_form_factors() {
    for d in [0.25, 1.0] {
        let (scene, f12) = facing_squares(d, 1e-9);
        let sol = solve(
            &scene,
            &SolverConfig {
                eps: 1e-3,
                max_level: 3,
                ..SolverConfig::default()
            },
        )
        .unwrap();
        let loss = sol.energy.operator_loss[0];
        println!("d {d}: operator loss {loss:.6} vs exact {:.6}", 1.0 - f12);
        assert!(
            (loss - (1.0 - f12)).abs() <= 1e-2 * f12,
            "d {d}: {loss} vs {}",
            1.0 - f12
        );
    }
}

/// Checks a closed-enclosure solution: every ray arrives, so `escaped` is exactly zero,
/// and the balance `emitted = absorbed + unshot` is the operator's row sums; returns a
/// message when the imbalance exceeds 1 % of the emitted power — the accuracy of the
/// singular (Sauter–Schwab) and regular rules on the edge-adjacent faces of the
/// furnace cube — or the solution never reached level 4.
fn closed_check(name: &str, sol: &Solution, seconds: f64) -> Option<String> {
    let e = sol.energy;
    let em = e.emitted[0];
    let imb = e.imbalance()[0];
    println!(
        "{name}: level {}, leaves {}, escaped {:.2e}, operator loss {:.2e}, imbalance {:.2e} ({seconds:.1} s)",
        deepest_level(sol),
        sol.stats.leaves,
        e.escaped[0] / em,
        e.operator_loss[0] / em,
        imb / em
    );
    assert_eq!(e.escaped, [0.0; 3], "{name}: rays left a closed cube");
    assert!(e.escape_rays > 0);
    if deepest_level(sol) < 4 {
        return Some(format!("{name}: not refined to level 4"));
    }
    (imb.abs() > 1e-2 * em).then(|| format!("{name}: imbalance {:.3e}", imb / em))
}

/// Closed enclosure, gathering, refined to level 4: the operator's row sums balance the
/// emitted power to 1 % for every basis (Haar, M2, M3, CDV). Haar needs a smaller ε to
/// reach level 4 in the uniform furnace; before the exact, energy-conserving transfer
/// blocks (issue 11) its imbalance here was −1.53 %.
#[test]
fn closed_enclosure_gathering_balances_at_level_four() {
    let scene = white_furnace(1.0, 0.5).unwrap();
    let mut failures = Vec::new();
    for (basis, eps) in [
        (BasisKind::Haar, 2e-2),
        (BasisKind::Multiwavelet(2), 5e-2),
        (BasisKind::Multiwavelet(3), 5e-2),
        (BasisKind::Cdv, 5e-2),
    ] {
        let t = std::time::Instant::now();
        let sol = solve(
            &scene,
            &SolverConfig {
                basis,
                eps,
                max_level: 4,
                linear_method: LinearMethod::Gmres { restart: 30 },
                tolerance: 1e-10,
                ..SolverConfig::default()
            },
        )
        .unwrap();
        let name = format!("gather {}", basis.name());
        failures.extend(closed_check(&name, &sol, t.elapsed().as_secs_f64()));
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// Closed enclosure, shooting, every tree basis refined to level 4 (a few rounds of
/// shots: the unshot rest is part of the balance).
#[test]
fn closed_enclosure_shooting_balances_at_level_four() {
    let scene = white_furnace(1.0, 0.5).unwrap();
    let mut failures = Vec::new();
    for basis in [
        BasisKind::Haar,
        BasisKind::Multiwavelet(2),
        BasisKind::Multiwavelet(3),
    ] {
        let t = std::time::Instant::now();
        let sol = shoot(
            &scene,
            &ShootConfig {
                basis,
                eps: 1e-2,
                max_level: 4,
                convergence: 0.6,
                ..ShootConfig::default()
            },
        )
        .unwrap();
        let name = format!("shoot {}", basis.name());
        failures.extend(closed_check(&name, &sol, t.elapsed().as_secs_f64()));
    }
    assert!(failures.is_empty(), "{failures:#?}");
}

/// An open scene with occlusion (Ziegler's "Occluded": a receiver, an emitting square
/// in a parallel reflecting square, a blocker between them): the measured escaped power
/// balances the operator's absorbed and unshot power within four standard errors plus
/// 1 % of the emitted power (the transfer blocks' accuracy, as above), for gathering and
/// shooting.
#[test]
fn open_scene_balances_against_measured_escape() {
    let scene = wavelux_scene::builtin::occluded();
    let gather = solve(
        &scene,
        &SolverConfig {
            basis: BasisKind::Multiwavelet(2),
            eps: 1e-2,
            max_level: 3,
            linear_method: LinearMethod::Gmres { restart: 30 },
            tolerance: 1e-10,
            ..SolverConfig::default()
        },
    )
    .unwrap();
    let shot = shoot(
        &scene,
        &ShootConfig {
            max_level: 3,
            convergence: 0.99,
            ..ShootConfig::default()
        },
    )
    .unwrap();
    for (name, sol) in [("gather", &gather), ("shoot", &shot)] {
        let e = sol.energy;
        for c in 0..3 {
            let (em, imb, se) = (e.emitted[c], e.imbalance()[c], e.escaped_std_error[c]);
            println!(
                "{name} ch {c}: escaped {:.4} ± {:.1e}, operator loss {:.4}, imbalance {:.2e}",
                e.escaped[c] / em,
                se / em,
                e.operator_loss[c] / em,
                imb / em
            );
            assert!(e.escaped[c] > 0.0, "{name}: the scene is open");
            assert!(
                imb.abs() <= 4.0 * se + 1e-2 * em,
                "{name} ch {c}: imbalance {} (σ {})",
                imb / em,
                se / em
            );
        }
    }
}
