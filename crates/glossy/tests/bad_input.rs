//! Bad input to the glossy method (issue 16, "Bad input"): typed errors naming the
//! file and element, warnings for suspicious but solvable scenes, and budgets that end
//! refinement without ending the run.

mod common;

use glam::DVec3;
use wavelux_glossy::{GlossyConfig, GlossyError, GlossySolution, ImportanceSource, WardVariant};

fn solve(
    scene: &wavelux_scene::Scene,
    config: GlossyConfig,
) -> Result<GlossySolution, GlossyError> {
    GlossySolution::new(scene, "bad.toml", config)
}

/// The error of a run that must fail.
fn fails(r: Result<GlossySolution, GlossyError>) -> GlossyError {
    match r {
        Ok(_) => panic!("bad input was accepted"),
        Err(e) => e,
    }
}

#[test]
fn tangent_along_the_normal_names_file_and_surface() {
    let mut scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    scene
        .tangents
        .insert("patch2".into(), DVec3::new(0.0, 0.0, 2.0));
    let err = fails(solve(&scene, GlossyConfig::default()));
    let msg = err.to_string();
    assert!(matches!(err, GlossyError::Scene { .. }), "{err:?}");
    assert!(
        msg.contains("bad.toml") && msg.contains("patch2") && msg.contains("tangent"),
        "{msg}"
    );
    // A tangent with a normal component is projected, not rejected.
    scene
        .tangents
        .insert("patch2".into(), DVec3::new(1.0, 0.0, 1.0));
    assert!(
        solve(
            &scene,
            GlossyConfig {
                rounds: 0,
                ..GlossyConfig::default()
            }
        )
        .is_ok()
    );
}

#[test]
fn importance_without_a_source_is_a_typed_error() {
    let scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    let empty = GlossyConfig {
        importance: ImportanceSource::Surfaces(Vec::new()),
        ..GlossyConfig::default()
    };
    let err = fails(solve(&scene, empty));
    assert!(matches!(err, GlossyError::NoImportanceSource(_)), "{err:?}");
    assert!(err.to_string().contains("bad.toml"), "{err}");
    let unknown = GlossyConfig {
        importance: ImportanceSource::Surfaces(vec!["nowhere".into()]),
        ..GlossyConfig::default()
    };
    let err = fails(solve(&scene, unknown));
    let msg = err.to_string();
    assert!(msg.contains("bad.toml") && msg.contains("nowhere"), "{msg}");
}

#[test]
fn non_finite_or_out_of_range_knobs_are_rejected() {
    let scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    let cases = [
        GlossyConfig {
            tolerance: f64::NAN,
            ..GlossyConfig::default()
        },
        GlossyConfig {
            fraction: 0.0,
            ..GlossyConfig::default()
        },
        GlossyConfig {
            fraction: f64::INFINITY,
            ..GlossyConfig::default()
        },
        GlossyConfig {
            image_tolerance: Some(f64::NAN),
            ..GlossyConfig::default()
        },
        GlossyConfig {
            importance_rays: 0,
            ..GlossyConfig::default()
        },
        GlossyConfig {
            max_iterations: 0,
            ..GlossyConfig::default()
        },
    ];
    for c in cases {
        let err = fails(solve(&scene, c.clone()));
        assert!(matches!(err, GlossyError::Invalid { .. }), "{c:?}: {err:?}");
    }
}

#[test]
fn non_finite_or_non_positive_roughness_names_the_material() {
    for alpha in [f64::NAN, 0.0, -0.2, f64::INFINITY] {
        let mut scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
        for m in &mut scene.materials {
            if let Some(w) = &mut m.ward {
                w.alpha_x = alpha;
            }
        }
        let err = fails(solve(&scene, GlossyConfig::default()));
        let msg = err.to_string();
        assert!(
            msg.contains("bad.toml") && msg.contains("glossy"),
            "α = {alpha}: {msg}"
        );
    }
}

#[test]
fn sharp_lobes_and_albedo_above_one_warn_but_solve() {
    let mut scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    for m in &mut scene.materials {
        if let Some(w) = &mut m.ward {
            w.alpha_x = 0.005;
        }
    }
    let sol = solve(
        &scene,
        GlossyConfig {
            rounds: 0,
            ..GlossyConfig::default()
        },
    )
    .unwrap();
    assert!(
        sol.stats
            .warnings
            .iter()
            .any(|w| w.contains("roughness") && w.contains("bad.toml")),
        "{:?}",
        sol.stats.warnings
    );
    // Product at α = 0.2 reaches albedo ≈ 3.4 at 89°: ρ_s = 0.5 exceeds 1 there.
    let scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    let product = GlossyConfig {
        variant: WardVariant::Product,
        rounds: 0,
        ..GlossyConfig::default()
    };
    let sol = solve(&scene, product).unwrap();
    assert!(
        sol.stats
            .warnings
            .iter()
            .any(|w| w.contains("albedo") && w.contains("product")),
        "{:?}",
        sol.stats.warnings
    );
    // Bounded never warns about albedo at ρ_s = 0.5.
    let sol = solve(
        &scene,
        GlossyConfig {
            rounds: 0,
            ..GlossyConfig::default()
        },
    )
    .unwrap();
    assert!(
        !sol.stats.warnings.iter().any(|w| w.contains("albedo")),
        "{:?}",
        sol.stats.warnings
    );
}

#[test]
fn link_budget_ends_refinement_not_the_run() {
    let scene = common::three_patches(std::f64::consts::PI, 0.0, 0.5, 0.5);
    let free = solve(
        &scene,
        GlossyConfig {
            rounds: 0,
            ..GlossyConfig::default()
        },
    )
    .unwrap();
    let initial = free.links.len();
    let mut sol = solve(
        &scene,
        GlossyConfig {
            rounds: 3,
            max_links: initial + 1,
            ..GlossyConfig::default()
        },
    )
    .unwrap();
    sol.run(|_| {}).unwrap();
    assert!(sol.stats.stop.contains("budget"), "{}", sol.stats.stop);
    assert!(sol.links.len() <= initial + 1, "{} links", sol.links.len());
    assert!(sol.radiance(1, glam::DVec2::splat(0.5), DVec3::Z)[0].is_finite());
}
