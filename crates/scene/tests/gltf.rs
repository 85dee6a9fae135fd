//! glTF loader tests: round trips through `.gltf` (data URI and external buffer) and
//! `.glb`, node transforms, names, materials and emission conversion, sidedness,
//! textures, cameras, and typed errors on bad input.

mod common;

use common::{MatSpec, MeshSpec, glb, gltf_embedded, png_rgb8, unit_square};
use glam::DVec3;
use wavelux_scene::{
    GltfOptions, MeshElement, ReflectancePolicy, SceneError, Shape, Sidedness, WarningKind,
    builtin, load, load_gltf, load_gltf_slice,
};

fn opts() -> GltfOptions {
    GltfOptions::default()
}

/// Exports every mesh/parallelogram surface of a built-in scene as glTF triangles.
fn export(scene: &wavelux_scene::Scene) -> (Vec<MeshSpec>, Vec<MatSpec>) {
    let mats = scene
        .materials
        .iter()
        .map(|m| {
            let l = m.emission.scale(1.0 / std::f64::consts::PI);
            let strength = l.max_channel().max(1.0);
            MatSpec {
                name: Some(m.name.clone()),
                base_color: [
                    m.reflectance.0[0] as f32,
                    m.reflectance.0[1] as f32,
                    m.reflectance.0[2] as f32,
                    1.0,
                ],
                emissive: l.scale(1.0 / strength).0.map(|x| x as f32),
                strength: Some(strength as f32),
                double_sided: false,
                base_color_image: None,
            }
        })
        .collect();
    let mut meshes = Vec::new();
    for s in &scene.surfaces {
        let elements: Vec<MeshElement> = match &s.shape {
            Shape::Mesh(m) => m.elements().collect(),
            Shape::Parallelogram {
                origin,
                edge_u,
                edge_v,
            } => vec![MeshElement::Parallelogram {
                origin: *origin,
                edge_u: *edge_u,
                edge_v: *edge_v,
            }],
            Shape::Triangle(t) => vec![MeshElement::Triangle(*t)],
            _ => continue,
        };
        let mut pos = Vec::new();
        let mut ind = Vec::new();
        for e in elements {
            let b = pos.len() as u32;
            match e {
                MeshElement::Triangle(t) => {
                    pos.extend(t.map(|p| p.as_vec3().to_array()));
                    ind.extend([b, b + 1, b + 2]);
                }
                MeshElement::Parallelogram {
                    origin,
                    edge_u,
                    edge_v,
                } => {
                    for p in [
                        origin,
                        origin + edge_u,
                        origin + edge_u + edge_v,
                        origin + edge_v,
                    ] {
                        pos.push(p.as_vec3().to_array());
                    }
                    ind.extend([b, b + 1, b + 2, b, b + 2, b + 3]);
                }
            }
        }
        meshes.push(MeshSpec::new(&s.name, pos, ind, s.material));
    }
    (meshes, mats)
}

fn rel(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs().max(1e-300)
}

fn check_round_trip(original: &wavelux_scene::Scene, loaded: &wavelux_scene::Scene) {
    let mut n = 0;
    for s in &original.surfaces {
        if matches!(s.shape, Shape::Polygon(_)) {
            continue;
        }
        n += 1;
        let l = loaded
            .surface(&s.name)
            .unwrap_or_else(|| panic!("surface {} lost", s.name));
        // f32 storage: relative area error a few f32 ulps.
        assert!(
            rel(l.shape.area(), s.shape.area()) < 1e-6,
            "{}: {} vs {}",
            s.name,
            l.shape.area(),
            s.shape.area()
        );
        assert_eq!(
            l.shape.element_count(),
            s.shape.element_count(),
            "{}",
            s.name
        );
        assert_eq!(l.sides, Sidedness::OneSided);
        let (mo, ml) = (
            &original.materials[s.material],
            &loaded.materials[l.material],
        );
        assert_eq!(mo.name, ml.name);
        for c in 0..3 {
            assert!((mo.reflectance.0[c] - ml.reflectance.0[c]).abs() < 1e-7);
            assert!(rel(ml.emission.0[c], mo.emission.0[c]) < 1e-6 || mo.emission.0[c] == 0.0);
            assert!(mo.emission.0[c] != 0.0 || ml.emission.0[c] == 0.0);
        }
        // Front sides survive (normals agree).
        let normals = |sh: &Shape| -> Vec<DVec3> {
            match sh {
                Shape::Mesh(m) => m.elements().map(|e| e.normal()).collect(),
                Shape::Parallelogram { edge_u, edge_v, .. } => {
                    vec![edge_u.cross(*edge_v).normalize()]
                }
                _ => vec![],
            }
        };
        let sum = |v: Vec<DVec3>| v.into_iter().fold(DVec3::ZERO, |a, b| a + b);
        assert!(sum(normals(&s.shape)).dot(sum(normals(&l.shape))) > 0.0);
    }
    assert_eq!(n, loaded.surfaces.len());
}

#[test]
fn round_trip_white_furnace_gltf_and_glb() {
    let scene = builtin::white_furnace(2.0, 0.5).unwrap();
    let (meshes, mats) = export(&scene);
    let text = gltf_embedded(&meshes, &mats, &[]);
    let a = load_gltf_slice(text.as_bytes(), "furnace.gltf", None, &opts()).unwrap();
    check_round_trip(&scene, &a);
    // Each unit square comes back as ONE merged parallelogram.
    for s in &a.surfaces {
        let Shape::Mesh(m) = &s.shape else {
            panic!("mesh expected")
        };
        assert_eq!((m.parallelograms.len(), m.triangles.len()), (1, 0));
    }
    let bin = glb(&meshes, &mats, &[]);
    let b = load_gltf_slice(&bin, "furnace.glb", None, &opts()).unwrap();
    check_round_trip(&scene, &b);
    assert!(a.warnings.is_empty() && b.warnings.is_empty());
}

#[test]
fn round_trip_cornell_and_ziegler_through_files() {
    let dir = tempfile::tempdir().unwrap();
    for scene in [
        builtin::cornell_box(),
        builtin::unoccluded(),
        builtin::ziegler_box(true, builtin::Reflectivity::High, builtin::BoxVariant::B),
    ] {
        let (meshes, mats) = export(&scene);
        // External .bin buffer next to the .gltf.
        let (root, bin) = common::build(&meshes, &mats, &[], Some("scene.bin"));
        std::fs::write(dir.path().join("scene.bin"), &bin).unwrap();
        let path = dir.path().join("scene.gltf");
        std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
        let loaded = load_gltf(&path, &opts()).unwrap();
        check_round_trip(&scene, &loaded);
        assert_eq!(loaded.name, "scene");
        // Same through the extension dispatcher and a .glb.
        let glb_path = dir.path().join("scene.glb");
        std::fs::write(&glb_path, glb(&meshes, &mats, &[])).unwrap();
        check_round_trip(&scene, &load(&glb_path).unwrap());
    }
}

#[test]
fn emission_is_pi_times_emissive_times_strength() {
    let (p, i) = unit_square(1.0);
    let mut m = MatSpec::grey("lamp", 0.5);
    m.emissive = [1.0, 0.5, 0.25];
    m.strength = Some(8.0);
    let text = gltf_embedded(&[MeshSpec::new("lamp", p, i, 0)], &[m], &[]);
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()).unwrap();
    let e = s.materials[0].emission.0;
    let pi = std::f64::consts::PI;
    assert_eq!(e, [pi * 8.0, pi * 4.0, pi * 2.0]);
    let power = s.emitted_power();
    assert!((power[0] - pi * 8.0).abs() < 1e-12);
}

#[test]
fn double_sided_gives_two_independent_sides() {
    let (p, i) = unit_square(1.0);
    let mut m = MatSpec::grey("two", 0.3);
    m.double_sided = true;
    let text = gltf_embedded(
        &[
            MeshSpec::new("a", p.clone(), i.clone(), 0),
            MeshSpec::new("b", p, i, 1),
        ],
        &[m, MatSpec::grey("one", 0.3)],
        &[],
    );
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()).unwrap();
    let a = s.surface("a").unwrap();
    assert_eq!(a.sides, Sidedness::TwoSided { back: a.material });
    assert_eq!(s.surface("b").unwrap().sides, Sidedness::OneSided);
}

#[test]
fn node_transforms_and_winding_flip() {
    let (p, i) = unit_square(1.0);
    // Scale x by 2, mirror z (det < 0), translate by (1, 2, 3); column-major.
    let m = [
        2.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, -1.0, 0.0, 1.0, 2.0, 3.0, 1.0,
    ];
    let mut spec = MeshSpec::new("moved", p.clone(), i.clone(), 0);
    spec.matrix = Some(m);
    // A pure mirror x → −x: the square's normal +z must stay +z after the flip.
    let mut mirror = MeshSpec::new("mirrored", p, i, 0);
    mirror.matrix = Some([
        -1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
    ]);
    let text = gltf_embedded(&[spec, mirror], &[MatSpec::grey("w", 0.5)], &[]);
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()).unwrap();
    let moved = s.surface("moved").unwrap();
    assert!((moved.shape.area() - 2.0).abs() < 1e-12);
    let Shape::Mesh(mesh) = &moved.shape else {
        panic!()
    };
    assert!(mesh.positions.contains(&DVec3::new(3.0, 2.0, 3.0)));
    // Mirroring z alone keeps the geometric normal +z (the plane is z = 3), and the
    // glTF rule (det < 0 ⇒ clockwise front) makes the front the mirror image: −z.
    for e in mesh.elements() {
        assert!((e.normal() - DVec3::new(0.0, 0.0, -1.0)).length() < 1e-12);
    }
    let Shape::Mesh(mirrored) = &s.surface("mirrored").unwrap().shape else {
        panic!()
    };
    for e in mirrored.elements() {
        assert!((e.normal() - DVec3::Z).length() < 1e-12);
    }
}

#[test]
fn names_fall_back_to_mesh_then_generated_and_are_unique() {
    let (p, i) = unit_square(1.0);
    let mut a = MeshSpec::new("x", p.clone(), i.clone(), 0);
    a.node_name = None;
    a.mesh_name = Some("wall".into());
    let mut b = a.clone();
    b.mesh_name = None;
    let c = MeshSpec::new("dup", p.clone(), i.clone(), 0);
    let d = MeshSpec::new("dup", p, i, 0);
    let text = gltf_embedded(&[a, b, c, d], &[MatSpec::grey("w", 0.5)], &[]);
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()).unwrap();
    let names: Vec<&str> = s.surfaces.iter().map(|s| s.name.as_str()).collect();
    assert_eq!(names, ["wall", "mesh1.prim0", "dup", "dup#2"]);
}

#[test]
fn degenerate_triangles_are_dropped_with_a_count() {
    let (mut p, mut i) = unit_square(1.0);
    // Two zero-area triangles: collinear and repeated vertex.
    p.extend([[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]]);
    i.extend([4, 5, 6, 4, 4, 5]);
    let text = gltf_embedded(
        &[MeshSpec::new("s", p, i, 0)],
        &[MatSpec::grey("w", 0.5)],
        &[],
    );
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()).unwrap();
    assert_eq!(s.surfaces.len(), 1);
    assert!((s.total_area() - 1.0).abs() < 1e-12);
    assert_eq!(
        s.warnings.iter().map(|w| &w.kind).collect::<Vec<_>>(),
        [&WarningKind::DegenerateTrianglesDropped { count: 2 }]
    );
    assert_eq!(s.warnings[0].file, "t.gltf");
    // A primitive made only of degenerate triangles has zero area: a typed error naming
    // the file and the primitive, not a surface silently dropped.
    let text = gltf_embedded(
        &[MeshSpec::new(
            "flat",
            vec![[0.0; 3], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]],
            vec![0, 1, 2],
            0,
        )],
        &[MatSpec::grey("w", 0.5)],
        &[],
    );
    match load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()) {
        Err(SceneError::Degenerate { file, element, .. }) => {
            assert_eq!(file, "t.gltf");
            assert!(element.contains("mesh 0 primitive 0"), "{element}");
        }
        other => panic!("expected a zero-area error, got {other:?}"),
    }
}

#[test]
fn bad_values_give_typed_errors_naming_file_and_element() {
    let (p, i) = unit_square(1.0);
    // Reflectance 1 (glTF's default white) is rejected...
    let text = gltf_embedded(
        &[MeshSpec::new("s", p.clone(), i.clone(), 0)],
        &[MatSpec::grey("white", 1.0)],
        &[],
    );
    match load_gltf_slice(text.as_bytes(), "w.gltf", None, &opts()) {
        Err(SceneError::InvalidReflectance {
            file,
            element,
            value,
        }) => {
            assert_eq!(
                (file.as_str(), element.as_str(), value),
                ("w.gltf", "material 0", 1.0)
            );
        }
        other => panic!("{other:?}"),
    }
    // ... or clamped with a warning under the Clamp policy.
    let clamp = GltfOptions {
        reflectance_policy: ReflectancePolicy::Clamp { max: 0.95 },
        ..GltfOptions::default()
    };
    let s = load_gltf_slice(text.as_bytes(), "w.gltf", None, &clamp).unwrap();
    assert_eq!(s.materials[0].reflectance.0, [0.95; 3]);
    assert_eq!(s.warnings.len(), 3);
    // Negative reflectance.
    let mut neg = MatSpec::grey("neg", 0.5);
    neg.base_color[1] = -0.25;
    let text = gltf_embedded(&[MeshSpec::new("s", p.clone(), i.clone(), 0)], &[neg], &[]);
    assert!(matches!(
        load_gltf_slice(text.as_bytes(), "n.gltf", None, &opts()),
        Err(SceneError::InvalidReflectance { value, .. }) if value == -0.25
    ));
    // Primitive without material → glTF default material (white, ρ = 1) → rejected.
    let mut nomat = MeshSpec::new("s", p.clone(), i.clone(), 0);
    nomat.material = None;
    let text = gltf_embedded(&[nomat], &[MatSpec::grey("w", 0.5)], &[]);
    assert!(matches!(
        load_gltf_slice(text.as_bytes(), "d.gltf", None, &opts()),
        Err(SceneError::InvalidReflectance { element, .. }) if element == "default material"
    ));
    // NaN and infinite coordinates.
    for bad in [f32::NAN, f32::INFINITY] {
        let mut q = p.clone();
        q[2][1] = bad;
        let text = gltf_embedded(
            &[MeshSpec::new("s", q, i.clone(), 0)],
            &[MatSpec::grey("w", 0.5)],
            &[],
        );
        match load_gltf_slice(text.as_bytes(), "nan.gltf", None, &opts()) {
            Err(SceneError::NonFinite {
                file,
                element,
                what,
                ..
            }) => {
                assert_eq!(file, "nan.gltf");
                assert_eq!(element, "mesh 0 primitive 0 (node 0)");
                assert_eq!(what, "vertex 2");
            }
            other => panic!("{other:?}"),
        }
    }
    // Index out of range.
    let text = gltf_embedded(
        &[MeshSpec::new("s", p.clone(), vec![0, 1, 9], 0)],
        &[MatSpec::grey("w", 0.5)],
        &[],
    );
    assert!(matches!(
        load_gltf_slice(text.as_bytes(), "i.gltf", None, &opts()),
        Err(SceneError::Malformed { .. })
    ));
}

#[test]
fn malformed_structure_errors() {
    let (p, i) = unit_square(1.0);
    let text = gltf_embedded(
        &[MeshSpec::new("s", p, i, 0)],
        &[MatSpec::grey("w", 0.5)],
        &[],
    );
    let root: serde_json::Value = serde_json::from_str(&text).unwrap();
    // Node cycle: node 0 is its own child.
    let mut cyc = root.clone();
    cyc["nodes"][0]["children"] = serde_json::json!([0]);
    let r = load_gltf_slice(cyc.to_string().as_bytes(), "c.gltf", None, &opts());
    assert!(
        matches!(
            &r,
            Err(SceneError::Malformed { .. }) | Err(SceneError::Gltf { .. })
        ),
        "{r:?}"
    );
    // Accessor past the end of its view.
    let mut over = root.clone();
    over["accessors"][0]["count"] = serde_json::json!(1000);
    let r = load_gltf_slice(over.to_string().as_bytes(), "o.gltf", None, &opts());
    assert!(
        matches!(
            &r,
            Err(SceneError::Malformed { .. }) | Err(SceneError::Gltf { .. })
        ),
        "{r:?}"
    );
    // Sparse accessors are unsupported.
    let mut sparse = root.clone();
    sparse["accessors"][0]["sparse"] = serde_json::json!({
        "count": 1,
        "indices": {"bufferView": 1, "componentType": 5125},
        "values": {"bufferView": 0}
    });
    let r = load_gltf_slice(sparse.to_string().as_bytes(), "sp.gltf", None, &opts());
    assert!(
        matches!(
            &r,
            Err(SceneError::Unsupported { .. }) | Err(SceneError::Gltf { .. })
        ),
        "{r:?}"
    );
    // Unsupported required extension.
    let mut req = root.clone();
    req["extensionsRequired"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    req["extensionsUsed"] = serde_json::json!(["KHR_draco_mesh_compression"]);
    let r = load_gltf_slice(req.to_string().as_bytes(), "x.gltf", None, &opts());
    assert!(
        matches!(
            &r,
            Err(SceneError::Unsupported { .. }) | Err(SceneError::Gltf { .. })
        ),
        "{r:?}"
    );
    // Not JSON at all; truncated GLB; GLB with a bogus length.
    assert!(matches!(
        load_gltf_slice(b"hello", "h.gltf", None, &opts()),
        Err(SceneError::Gltf { file, .. }) if file == "h.gltf"
    ));
    assert!(load_gltf_slice(b"glTF\x02\0\0\0\x04\0\0\0", "g.glb", None, &opts()).is_err());
    assert!(load_gltf_slice(b"glTF\x02\0\0\0\xff\xff\0\0", "g.glb", None, &opts()).is_err());
    // Missing file.
    assert!(matches!(
        load_gltf("/nonexistent/dir/x.gltf", &opts()),
        Err(SceneError::Io { .. })
    ));
    assert!(matches!(
        load("scene.obj"),
        Err(SceneError::UnknownFormat { .. })
    ));
}

#[test]
fn textures_are_decoded_and_srgb_linearised() {
    let (p, i) = unit_square(1.0);
    // 2×1 image: sRGB 255 and 128.
    let png = png_rgb8(2, 1, &[255, 255, 255, 128, 64, 0]);
    let mut m = MatSpec::grey("tex", 0.5);
    m.base_color_image = Some(0);
    let mut spec = MeshSpec::new("s", p, i, 0);
    spec.uvs = Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    let text = gltf_embedded(&[spec.clone()], &[m.clone()], std::slice::from_ref(&png));
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()).unwrap();
    let tr = s.materials[0].reflectance_texture.unwrap();
    let t = &s.textures[tr.texture];
    assert_eq!((t.width, t.height), (2, 1));
    assert_eq!(t.texels[0].0, [1.0; 3]);
    let lin = wavelux_scene::material::srgb_to_linear(128.0 / 255.0);
    assert_eq!(t.texels[1].0[0], lin);
    assert_eq!(t.sample_nearest(0.75, 0.5), t.texels[1]);
    let Shape::Mesh(mesh) = &s.surfaces[0].shape else {
        panic!()
    };
    assert_eq!(mesh.uv_sets.len(), 1);
    // Factor 1 × white texel = 1 is rejected.
    m.base_color = [1.0, 1.0, 1.0, 1.0];
    let text = gltf_embedded(&[spec.clone()], &[m.clone()], std::slice::from_ref(&png));
    assert!(matches!(
        load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()),
        Err(SceneError::InvalidReflectance { .. })
    ));
    // Texture referring to a missing TEXCOORD set.
    spec.uvs = None;
    m.base_color = [0.5, 0.5, 0.5, 1.0];
    let text = gltf_embedded(&[spec.clone()], &[m.clone()], &[png]);
    assert!(matches!(
        load_gltf_slice(text.as_bytes(), "t.gltf", None, &opts()),
        Err(SceneError::Malformed { .. })
    ));
    // skip_textures keeps the factor only.
    let skip = GltfOptions {
        skip_textures: true,
        ..GltfOptions::default()
    };
    let s = load_gltf_slice(text.as_bytes(), "t.gltf", None, &skip).unwrap();
    assert!(s.materials[0].reflectance_texture.is_none());
}

#[test]
fn cameras_take_their_node_transform() {
    let (p, i) = unit_square(1.0);
    let text = gltf_embedded(
        &[MeshSpec::new("s", p, i, 0)],
        &[MatSpec::grey("w", 0.5)],
        &[],
    );
    let mut root: serde_json::Value = serde_json::from_str(&text).unwrap();
    root["cameras"] = serde_json::json!([{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01, "aspectRatio": 1.5}}]);
    // Rotate 90° about y (quaternion (0, sin45, 0, cos45)), translate (0, 1, 5).
    let h = std::f64::consts::FRAC_1_SQRT_2;
    root["nodes"]
        .as_array_mut()
        .unwrap()
        .push(serde_json::json!({
            "name": "eye", "camera": 0, "rotation": [0.0, h, 0.0, h], "translation": [0.0, 1.0, 5.0]
        }));
    root["scenes"][0]["nodes"] = serde_json::json!([0, 1]);
    let s = load_gltf_slice(root.to_string().as_bytes(), "c.gltf", None, &opts()).unwrap();
    assert_eq!(s.cameras.len(), 1);
    let c = &s.cameras[0];
    assert_eq!(c.name, "eye");
    assert!((c.position - DVec3::new(0.0, 1.0, 5.0)).length() < 1e-6);
    // −z rotated by +90° about y is −x.
    assert!((c.forward - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-6);
    assert!((c.up - DVec3::Y).length() < 1e-6);
    match c.projection {
        wavelux_scene::Projection::Perspective { yfov, aspect } => {
            assert!((yfov - 0.7).abs() < 1e-6);
            assert!((aspect.unwrap() - 1.5).abs() < 1e-6);
        }
        _ => panic!(),
    }
}
