//! Ward lobes from glTF materials (`wavelux_scene::gltf_ward`): Lambertian unless the
//! material opts in; `extras.ward` exact; `KHR_materials_specular` (+ anisotropy, ior)
//! by the documented approximate mapping; typed errors naming file and material.

mod common;

use common::{MatSpec, MeshSpec, gltf_embedded, unit_square};
use glam::DVec3;
use serde_json::{Value, json};
use wavelux_scene::{
    GltfOptions, Material, Rgb, SceneError, Shape, Sidedness, Surface, WardParams, WarningKind,
    load_gltf_slice, to_glb,
};

/// A one-square document with one grey material (base colour `base`, roughness
/// `roughness`) whose `extensions` and `extras` are set from the arguments.
fn doc(base: f64, roughness: f64, extensions: Option<Value>, extras: Option<Value>) -> String {
    let (p, i) = unit_square(1.0);
    let text = gltf_embedded(
        &[MeshSpec::new("s", p, i, 0)],
        &[MatSpec::grey("m", base as f32)],
        &[],
    );
    let mut root: Value = serde_json::from_str(&text).unwrap();
    let m = &mut root["materials"][0];
    m["pbrMetallicRoughness"]["roughnessFactor"] = json!(roughness);
    if let Some(e) = extensions {
        m["extensions"] = e;
    }
    if let Some(x) = extras {
        m["extras"] = x;
    }
    root.to_string()
}

fn load(text: &str) -> Result<wavelux_scene::Scene, SceneError> {
    load_gltf_slice(text.as_bytes(), "w.gltf", None, &GltfOptions::default())
}

fn close(a: f64, b: f64) -> bool {
    (a - b).abs() <= 1e-6 * b.abs().max(1e-12)
}

#[test]
fn materials_stay_lambertian_unless_they_opt_in() {
    let s = load(&doc(0.5, 0.3, None, Some(json!({"other": 1})))).unwrap();
    assert!(s.materials[0].ward.is_none());
    assert!(close(s.materials[0].reflectance.0[0], 0.5));
}

#[test]
fn extras_ward_is_exact_and_wins() {
    let s = load(&doc(
        0.4,
        0.9,
        Some(json!({"KHR_materials_specular": {"specularFactor": 1.0}})),
        Some(json!({"ward": {"specular": [0.1, 0.2, 0.3], "alpha_x": 0.05, "alpha_y": 0.2}})),
    ))
    .unwrap();
    let m = &s.materials[0];
    let w = m.ward.as_ref().unwrap();
    assert_eq!(w.specular.0, [0.1, 0.2, 0.3]);
    assert_eq!((w.alpha_x, w.alpha_y), (0.05, 0.2));
    assert!(close(m.reflectance.0[1], 0.4));
    // One number for the specular, alpha_y defaulting to alpha_x.
    let s = load(&doc(
        0.4,
        0.9,
        None,
        Some(json!({"ward": {"specular": 0.25, "alpha_x": 0.1}})),
    ))
    .unwrap();
    let w = s.materials[0].ward.as_ref().unwrap();
    assert_eq!(w.specular.0, [0.25; 3]);
    assert_eq!((w.alpha_x, w.alpha_y), (0.1, 0.1));
}

#[test]
fn khr_specular_maps_roughness_anisotropy_and_ior() {
    // α = roughness², ρ_s = factor · colour · F0(ior), ρ_d = base · (1 − max ρ_s),
    // α_x = α + (1 − α) s².
    let ior: f64 = 2.0;
    let f0 = ((ior - 1.0) / (ior + 1.0)).powi(2);
    let (rough, s_aniso) = (0.5, 0.6);
    let s = load(&doc(
        0.8,
        rough,
        Some(json!({
            "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1.0, 0.5, 0.25]},
            "KHR_materials_ior": {"ior": ior},
            "KHR_materials_anisotropy": {"anisotropyStrength": s_aniso},
        })),
        None,
    ))
    .unwrap();
    let m = &s.materials[0];
    let w = m.ward.as_ref().unwrap();
    let alpha = rough * rough;
    for (c, col) in [1.0, 0.5, 0.25].into_iter().enumerate() {
        assert!(close(w.specular.0[c], 0.5 * col * f0), "{:?}", w.specular);
        assert!(close(m.reflectance.0[c], 0.8 * (1.0 - 0.5 * f0)));
    }
    assert!(close(w.alpha_y, alpha));
    assert!(close(w.alpha_x, alpha + (1.0 - alpha) * s_aniso * s_aniso));
    // Defaults: factor 1, colour 1, ior 1.5 (F0 = 0.04), isotropic.
    let s = load(&doc(
        0.5,
        0.4,
        Some(json!({"KHR_materials_specular": {}})),
        None,
    ))
    .unwrap();
    let w = s.materials[0].ward.as_ref().unwrap();
    assert!(close(w.specular.0[0], 0.04));
    assert!(close(w.alpha_x, 0.16) && close(w.alpha_y, 0.16));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
}

#[test]
fn sharp_roughness_is_clamped_and_ignored_features_warn() {
    let s = load(&doc(
        0.5,
        0.05,
        Some(json!({
            "KHR_materials_specular": {"specularTexture": {"index": 0}},
            "KHR_materials_anisotropy": {"anisotropyStrength": 0.0, "anisotropyRotation": 0.5},
        })),
        None,
    ))
    .unwrap();
    let w = s.materials[0].ward.as_ref().unwrap();
    assert!(close(w.alpha_x, 0.01) && close(w.alpha_y, 0.01));
    let what: Vec<String> = s
        .warnings
        .iter()
        .map(|w| match &w.kind {
            WarningKind::Ignored { what } => what.clone(),
            k => panic!("unexpected warning {k:?}"),
        })
        .collect();
    assert_eq!(what.len(), 3, "{what:?}");
    assert!(what.iter().any(|w| w.contains("clamped")));
    assert!(what.iter().any(|w| w.contains("anisotropyRotation")));
    assert!(what.iter().any(|w| w.contains("specularTexture")));
    assert!(
        s.warnings
            .iter()
            .all(|w| w.file == "w.gltf" && w.element == "material 0")
    );
}

#[test]
fn bad_ward_values_give_typed_errors_naming_file_and_material() {
    let malformed = [
        doc(0.5, 0.5, None, Some(json!({"ward": {"specular": 0.1}}))),
        doc(0.5, 0.5, None, Some(json!({"ward": {"alpha_x": 0.1}}))),
        doc(
            0.5,
            0.5,
            None,
            Some(json!({"ward": {"specular": 0.1, "alpha_x": 0.0}})),
        ),
        doc(
            0.5,
            0.5,
            None,
            Some(json!({"ward": {"specular": 0.1, "alpha_x": -1.0}})),
        ),
        doc(
            0.5,
            0.5,
            None,
            Some(json!({"ward": {"specular": "x", "alpha_x": 0.1}})),
        ),
        doc(
            0.5,
            0.5,
            None,
            Some(json!({"ward": {"specular": [0.1, 0.1], "alpha_x": 0.1}})),
        ),
        doc(
            0.5,
            0.5,
            None,
            Some(json!({"ward": {"specular": 0.1, "alpha_x": 0.1, "alpha_y": "a"}})),
        ),
        doc(0.5, 0.5, None, Some(json!({"ward": 3}))),
        doc(
            0.5,
            0.5,
            Some(json!({"KHR_materials_specular": {"specularFactor": -1.0}})),
            None,
        ),
        doc(
            0.5,
            0.5,
            Some(json!({"KHR_materials_specular": {"specularColorFactor": [1, 1]}})),
            None,
        ),
        doc(0.5, 0.5, Some(json!({"KHR_materials_specular": 1})), None),
        doc(0.5, 0.0, Some(json!({"KHR_materials_specular": {}})), None),
        doc(
            0.5,
            0.5,
            Some(
                json!({"KHR_materials_specular": {}, "KHR_materials_anisotropy": {"anisotropyStrength": 2.0}}),
            ),
            None,
        ),
        doc(
            0.5,
            0.5,
            Some(json!({"KHR_materials_specular": {}, "KHR_materials_ior": {"ior": "glass"}})),
            None,
        ),
    ];
    for (k, text) in malformed.iter().enumerate() {
        match load(text) {
            Err(SceneError::Malformed { file, element, .. }) => {
                assert_eq!(file, "w.gltf");
                assert_eq!(element, "material 0", "case {k}");
            }
            r => panic!("case {k}: {r:?}"),
        }
    }
    // An exact lobe with ρ_d + ρ_s >= 1.
    let r = load(&doc(
        0.7,
        0.5,
        None,
        Some(json!({"ward": {"specular": 0.4, "alpha_x": 0.1}})),
    ));
    match r {
        Err(SceneError::InvalidReflectance { file, element, .. }) => {
            assert_eq!(file, "w.gltf");
            assert!(element.contains("\"m\""), "{element}");
        }
        r => panic!("{r:?}"),
    }
}

#[test]
fn ward_lobes_round_trip_through_glb() {
    let mut scene = wavelux_scene::Scene::new("w");
    let ward = WardParams {
        specular: Rgb([0.1, 0.2, 0.15]),
        alpha_x: 0.07,
        alpha_y: 0.3,
    };
    let mut glossy = Material::lambertian("glossy", Rgb::grey(0.5), Rgb::BLACK);
    glossy.ward = Some(ward);
    let id = scene.add_material(glossy);
    scene.add_surface(Surface {
        name: "floor".into(),
        shape: Shape::parallelogram(DVec3::ZERO, DVec3::X, DVec3::Y),
        material: id,
        sides: Sidedness::OneSided,
    });
    let glb = to_glb(&scene, "c.glb").unwrap();
    let back = load_gltf_slice(&glb, "c.glb", None, &GltfOptions::default()).unwrap();
    let got: Vec<&WardParams> = back
        .materials
        .iter()
        .filter_map(|m| m.ward.as_ref())
        .collect();
    assert_eq!(got, [&ward]);
    let m = back.materials.iter().find(|m| m.ward.is_some()).unwrap();
    assert_eq!(m.reflectance.0, [0.5; 3]);
}
