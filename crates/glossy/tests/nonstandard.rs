//! The non-standard decomposition (scaling links, push/pull; Glossy §3.5): the same
//! `V⁰` solution as the standard one, energy kept by push/pull in the white furnace,
//! convergence of patch 2 of Fig. 12 to its reference, and the importance restriction.

mod common;

use glam::{DVec2, DVec3};
use wavelux_glossy::*;

fn config(d: Decomposition, rounds: usize) -> GlossyConfig {
    GlossyConfig {
        variant: WardVariant::Original,
        decomposition: d,
        rounds,
        ..GlossyConfig::default()
    }
}

/// Relative L² error of patch 2's radiance (midpoint, 32 × 32 directions) against
/// `L₂ = f_r G L_e A₁` (Glossy §7.1).
fn error_patch2(sol: &GlossySolution) -> f64 {
    let lobe = WardLobe::new(WardVariant::Original, 0.2, 0.2).unwrap();
    let d = DVec3::new(0.5, 0.0, -1.0);
    let r2 = d.length_squared();
    let dir = d / r2.sqrt();
    let g = dir.z * dir.z / r2;
    let (mut e, mut n) = (0.0, 0.0);
    let k = 32;
    for i in 0..k {
        for j in 0..k {
            let u = DVec2::new((i as f64 + 0.5) / k as f64, (j as f64 + 0.5) / k as f64);
            let w = DirectionKind::Glossy.direction(u);
            let got = sol.radiance(1, DVec2::splat(0.5), w)[0];
            let r = 0.5 * lobe.eval(-dir, w) * g * 1e-4;
            e += (got - r).powi(2);
            n += r * r;
        }
    }
    (e / n).sqrt()
}

#[test]
fn non_standard_agrees_in_v0_and_converges_on_patch_two() {
    let scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    let std0 = GlossySolution::new(&scene, "three", config(Decomposition::Standard, 0)).unwrap();
    let mut ns =
        GlossySolution::new(&scene, "three", config(Decomposition::NonStandard, 2)).unwrap();
    assert_eq!(ns.links.len(), 0);
    assert_eq!(ns.scaling.len(), std0.links.len());
    // Same root links, same V⁰ solution (both solves stop at a change of 1e-6).
    for p in 0..3 {
        let (a, b) = (std0.exitance(p)[0], ns.exitance(p)[0]);
        assert!(
            (a - b).abs() <= 1e-5 * a.abs().max(1e-30),
            "patch {p}: {a} vs {b}"
        );
    }
    let mut errs = vec![error_patch2(&ns)];
    for _ in 0..2 {
        ns.refine_round().unwrap().unwrap();
        errs.push(error_patch2(&ns));
    }
    for w in errs.windows(2) {
        assert!(w[1] < w[0], "{errs:?}");
    }
    assert!(errs[2] < 0.8 * errs[0], "{errs:?}");
    assert_eq!(ns.links.len(), 0);
    assert_eq!(ns.stats.links, ns.scaling.len());
}

#[test]
fn push_and_pull_keep_the_white_furnace() {
    // A diffuse patch (ρ = 0.5) in a closed box of unit-radiance black emitters:
    // L = ρ everywhere. Splitting the walls' links into the patch's children and
    // pulling them back must keep it (the links of a refined link sum to the parent).
    let scene = common::furnace(
        1.0,
        wavelux_scene::Material::lambertian(
            "grey",
            wavelux_scene::Rgb::grey(0.5),
            wavelux_scene::Rgb::BLACK,
        ),
        0.1,
    );
    let mut sol = GlossySolution::new(
        &scene,
        "furnace",
        GlossyConfig {
            decomposition: Decomposition::NonStandard,
            fraction: 1e-9,
            rounds: 1,
            ..GlossyConfig::default()
        },
    )
    .unwrap();
    let before = sol.scaling.len();
    sol.run(|_| {}).unwrap();
    assert!(sol.scaling.len() > before, "refinement added no link");
    let patch = sol
        .scene
        .patches
        .iter()
        .position(|p| p.name.starts_with("patch"))
        .unwrap();
    for (i, j) in [(0.3, 0.3), (0.5, 0.5), (0.8, 0.2)] {
        let w = DirectionKind::Glossy.direction(DVec2::new(i, j));
        let l = sol.radiance(patch, DVec2::new(j, i), w)[0];
        assert!((l - 0.5).abs() < 5e-3, "({i}, {j}): {l}");
    }
}

#[test]
fn non_standard_with_importance_is_a_typed_error() {
    let scene = common::three_patches(1.0, 0.0, 0.5, 0.5);
    let err = GlossySolution::new(
        &scene,
        "three",
        GlossyConfig {
            decomposition: Decomposition::NonStandard,
            importance: ImportanceSource::Surfaces(vec!["patch3".into()]),
            ..GlossyConfig::default()
        },
    )
    .unwrap_err();
    assert!(
        matches!(
            err,
            GlossyError::Invalid {
                what: "decomposition",
                ..
            }
        ),
        "{err}"
    );
}
