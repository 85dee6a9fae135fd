//! Media in the native format and the glTF node extension `WAVELUX_medium`: grey and
//! RGB grids, raw f32 grid files, and the typed errors of bad grids (naming the file,
//! the medium or node, and the voxel).

mod common;

use wavelux_scene::{Rgb, SceneError, load_native, parse_native};

fn medium(grids: &str) -> String {
    format!(
        "[[medium]]\nname = \"m\"\nmin = [0,0,0]\nmax = [2,1,1]\nresolution = [2,1,1]\n{grids}\n"
    )
}

#[test]
fn grey_and_rgb_grids() {
    let s = parse_native(
        &medium("source = { rgb = [1, 2, 3] }\nopacity = [0.1, 0.2]\nalbedo = { values = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6], channels = 3 }"),
        "m.toml",
        None,
    )
    .unwrap();
    let m = &s.media[0];
    assert_eq!(m.source, vec![Rgb::new(1.0, 2.0, 3.0); 2]);
    assert_eq!(m.opacity, vec![0.1, 0.2]);
    assert_eq!(
        m.albedo,
        vec![Rgb::new(0.1, 0.2, 0.3), Rgb::new(0.4, 0.5, 0.6)]
    );
    // A grey file still loads as three equal channels.
    let s = parse_native(
        &medium("source = 2\nopacity = 0.5\nalbedo = 0.25"),
        "m.toml",
        None,
    )
    .unwrap();
    assert_eq!(s.media[0].albedo, vec![Rgb::grey(0.25); 2]);
}

fn write_f32(path: &std::path::Path, v: &[f32]) {
    let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_le_bytes()).collect();
    std::fs::write(path, bytes).unwrap();
}

#[test]
fn raw_grid_files() {
    let dir = tempfile::tempdir().unwrap();
    write_f32(&dir.path().join("op.raw"), &[0.25, 1.0]);
    write_f32(&dir.path().join("src.raw"), &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]);
    let scene = dir.path().join("s.toml");
    std::fs::write(
        &scene,
        medium("source = { file = \"src.raw\", channels = 3 }\nopacity = { file = \"op.raw\" }\nalbedo = 0.5"),
    )
    .unwrap();
    let s = load_native(&scene).unwrap();
    let m = &s.media[0];
    assert_eq!(m.opacity, vec![0.25, 1.0]);
    assert_eq!(m.source[1], Rgb::new(4.0, 5.0, 6.0));

    // A short file names the bytes expected and found.
    write_f32(&dir.path().join("short.raw"), &[0.5]);
    std::fs::write(
        &scene,
        medium("source = 0\nopacity = { file = \"short.raw\" }\nalbedo = 0.5"),
    )
    .unwrap();
    let e = load_native(&scene).unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, SceneError::Malformed { .. }), "{e:?}");
    assert!(
        msg.contains("4 bytes") && msg.contains("expected 8"),
        "{msg}"
    );
    assert!(msg.contains("medium \"m\" opacity"), "{msg}");
    // A missing file is an I/O error naming it.
    std::fs::write(
        &scene,
        medium("source = 0\nopacity = { file = \"nope.raw\" }\nalbedo = 0.5"),
    )
    .unwrap();
    let e = load_native(&scene).unwrap_err();
    assert!(
        matches!(e, SceneError::Io { ref file, .. } if file.ends_with("nope.raw")),
        "{e:?}"
    );
    // RGB opacity is rejected.
    std::fs::write(
        &scene,
        medium("source = 0\nopacity = { rgb = [0.1, 0.2, 0.3] }\nalbedo = 0.5"),
    )
    .unwrap();
    assert!(
        load_native(&scene)
            .unwrap_err()
            .to_string()
            .contains("grey")
    );
}

#[test]
fn bad_values_name_the_voxel() {
    let e = parse_native(
        &medium("source = 0\nopacity = [0.5, 1.5]\nalbedo = 0.5"),
        "m.toml",
        None,
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("voxel [1, 0, 0]") && msg.contains("opacity"),
        "{msg}"
    );
    let e = parse_native(
        &medium("source = 0\nopacity = 0.5\nalbedo = { rgb = [0.5, 1.0, 0.5] }"),
        "m.toml",
        None,
    )
    .unwrap_err();
    assert!(e.to_string().contains("albedo"), "{e}");
    let e = parse_native(
        &medium("source = nan\nopacity = 0.5\nalbedo = 0.5"),
        "m.toml",
        None,
    )
    .unwrap_err();
    assert!(matches!(e, SceneError::InvalidMedium { .. }), "{e:?}");
}

/// A `.gltf` with one node carrying `WAVELUX_medium` (`ext` is the extension's JSON)
/// and one FLOAT accessor per entry of `accessors` (`(type, values)`), in one data-URI
/// buffer.
fn gltf_medium(node: &str, ext: &str, accessors: &[(&str, Vec<f32>)]) -> String {
    let mut bin = Vec::new();
    let (mut views, mut accs) = (Vec::new(), Vec::new());
    for (i, (ty, vals)) in accessors.iter().enumerate() {
        let offset = bin.len();
        bin.extend(vals.iter().flat_map(|v| v.to_le_bytes()));
        let comps = if *ty == "VEC3" { 3 } else { 1 };
        views.push(format!(
            r#"{{"buffer":0,"byteOffset":{offset},"byteLength":{}}}"#,
            vals.len() * 4
        ));
        accs.push(format!(
            r#"{{"bufferView":{i},"componentType":5126,"count":{},"type":"{ty}"}}"#,
            vals.len() / comps
        ));
    }
    format!(
        r#"{{"asset":{{"version":"2.0"}},"extensionsUsed":["WAVELUX_medium"],
"buffers":[{{"byteLength":{},"uri":"data:application/octet-stream;base64,{}"}}],
"bufferViews":[{}],"accessors":[{}],
"scenes":[{{"nodes":[0]}}],"scene":0,
"nodes":[{{{node},"extensions":{{"WAVELUX_medium":{ext}}}}}]}}"#,
        bin.len(),
        common::base64(&bin),
        views.join(","),
        accs.join(",")
    )
}

#[test]
fn gltf_medium_extension() {
    use glam::DVec3;
    use wavelux_scene::{GltfOptions, load_gltf_slice};
    let opacity: Vec<f32> = (0..8).map(|i| i as f32 / 8.0).collect();
    let albedo: Vec<f32> = (0..24).map(|i| i as f32 / 48.0).collect();
    let text = gltf_medium(
        r#""name":"haze","translation":[1,2,3],"scale":[2,2,2]"#,
        r#"{"resolution":[2,2,2],"opacity":{"accessor":0},"source":[1,2,3],"albedo":{"accessor":1}}"#,
        &[("SCALAR", opacity.clone()), ("VEC3", albedo.clone())],
    );
    let s = load_gltf_slice(text.as_bytes(), "m.gltf", None, &GltfOptions::default()).unwrap();
    assert_eq!(s.media.len(), 1);
    let m = &s.media[0];
    assert_eq!(m.name, "haze");
    assert_eq!(
        (m.min, m.max),
        (DVec3::new(1.0, 2.0, 3.0), DVec3::new(3.0, 4.0, 5.0))
    );
    assert_eq!(m.resolution, [2, 2, 2]);
    let op: Vec<f64> = opacity.iter().map(|&v| f64::from(v)).collect();
    assert_eq!(m.opacity, op);
    assert_eq!(m.source, vec![Rgb::new(1.0, 2.0, 3.0); 8]);
    assert_eq!(
        m.albedo[5],
        Rgb::new(
            f64::from(albedo[15]),
            f64::from(albedo[16]),
            f64::from(albedo[17])
        )
    );

    let load = |node: &str, ext: &str, acc: &[(&str, Vec<f32>)]| {
        load_gltf_slice(
            gltf_medium(node, ext, acc).as_bytes(),
            "m.gltf",
            None,
            &GltfOptions::default(),
        )
    };
    // A rotated node is refused: media are axis-aligned boxes.
    let e = load(
        r#""rotation":[0,0,0.7071068,0.7071068]"#,
        r#"{"resolution":[1,1,1],"opacity":0.5,"source":0,"albedo":0.5}"#,
        &[],
    )
    .unwrap_err();
    assert!(matches!(e, SceneError::Unsupported { .. }), "{e:?}");
    assert!(e.to_string().contains("node 0 WAVELUX_medium"), "{e}");
    // Too few elements names the grid, the accessor and the counts.
    let e = load(
        r#""name":"m""#,
        r#"{"resolution":[2,2,2],"opacity":{"accessor":0},"source":0,"albedo":0.5}"#,
        &[("SCALAR", vec![0.5; 4])],
    )
    .unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("opacity accessor 0 has 4 elements, expected 8"),
        "{msg}"
    );
    // RGB opacity, an unknown field, a missing accessor and an out-of-range value.
    for (ext, want) in [
        (
            r#"{"resolution":[1,1,1],"opacity":[0.1,0.2,0.3],"source":0,"albedo":0.5}"#,
            "grey",
        ),
        (
            r#"{"resolution":[1,1,1],"opacity":0.5,"source":0,"albedo":0.5,"x":1}"#,
            "unknown field",
        ),
        (
            r#"{"resolution":[1,1,1],"opacity":{"accessor":7},"source":0,"albedo":0.5}"#,
            "accessor 7",
        ),
        (
            r#"{"resolution":[1,1,1],"opacity":1.5,"source":0,"albedo":0.5}"#,
            "opacity",
        ),
        (
            r#"{"resolution":[0,1,1],"opacity":0.5,"source":0,"albedo":0.5}"#,
            "resolution",
        ),
    ] {
        let e = load(r#""name":"m""#, ext, &[("SCALAR", vec![0.5])]).unwrap_err();
        assert!(e.to_string().contains(want), "{ext}: {e}");
    }
}
