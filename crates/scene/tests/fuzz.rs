//! The loaders never panic: arbitrary bytes, and random corruptions of valid glTF
//! JSON and GLB files, always give `Ok` or a typed error.

mod common;

use common::{MatSpec, MeshSpec, glb, gltf_embedded, unit_square};
use proptest::prelude::*;
use wavelux_scene::{GltfOptions, load_gltf_slice};

fn valid_files() -> (String, Vec<u8>) {
    let (p, i) = unit_square(1.0);
    let meshes = [
        MeshSpec::new("a", p.clone(), i.clone(), 0),
        MeshSpec::new("b", p, i, 1),
    ];
    let mut lamp = MatSpec::grey("lamp", 0.2);
    lamp.emissive = [1.0, 1.0, 1.0];
    let mats = [MatSpec::grey("w", 0.5), lamp];
    (gltf_embedded(&meshes, &mats, &[]), glb(&meshes, &mats, &[]))
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512)) {
        let _ = load_gltf_slice(&bytes, "fuzz.gltf", None, &GltfOptions::default());
        // Also as a would-be GLB.
        let mut glb = b"glTF".to_vec();
        glb.extend_from_slice(&bytes);
        let _ = load_gltf_slice(&glb, "fuzz.glb", None, &GltfOptions::default());
    }

    #[test]
    fn corrupted_glb_never_panics(edits in proptest::collection::vec((any::<usize>(), any::<u8>()), 1..8)) {
        let (_, mut bytes) = valid_files();
        for (pos, b) in edits {
            let n = bytes.len();
            bytes[pos % n] = b;
        }
        let _ = load_gltf_slice(&bytes, "fuzz.glb", None, &GltfOptions::default());
    }

    #[test]
    fn corrupted_json_numbers_never_panic(
        edits in proptest::collection::vec((any::<usize>(), prop_oneof![
            Just("0"), Just("-1"), Just("4294967295"), Just("1e308"), Just("99999"), Just("3"), Just("5126"), Just("5121")
        ]), 1..6)
    ) {
        let (text, _) = valid_files();
        // Replace random numeric tokens of the JSON with awkward values.
        let mut tokens: Vec<String> = Vec::new();
        let mut cur = String::new();
        for ch in text.chars() {
            if ch.is_ascii_digit() || ch == '.' || ch == '-' || ch == 'e' && !cur.is_empty() {
                cur.push(ch);
            } else {
                if !cur.is_empty() { tokens.push(std::mem::take(&mut cur)); }
                tokens.push(ch.to_string());
            }
        }
        if !cur.is_empty() { tokens.push(cur); }
        let numeric: Vec<usize> = tokens.iter().enumerate()
            .filter(|(_, t)| t.starts_with(|c: char| c.is_ascii_digit() || c == '-'))
            .map(|(i, _)| i).collect();
        for (pos, val) in edits {
            if !numeric.is_empty() {
                tokens[numeric[pos % numeric.len()]] = val.to_string();
            }
        }
        let s: String = tokens.concat();
        let _ = load_gltf_slice(s.as_bytes(), "fuzz.gltf", None, &GltfOptions::default());
    }
}
