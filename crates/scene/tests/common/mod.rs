//! A minimal glTF 2.0 writer for the tests (JSON via serde_json, binary buffer by
//! hand), so that loader tests can round-trip scenes through real glTF files.

#![allow(dead_code)]

use serde_json::{Value, json};

/// One material.
#[derive(Clone, Debug)]
pub struct MatSpec {
    pub name: Option<String>,
    pub base_color: [f32; 4],
    pub emissive: [f32; 3],
    pub strength: Option<f32>,
    pub double_sided: bool,
    /// Index into the images (PNG bytes) given to the writer, with TEXCOORD set 0.
    pub base_color_image: Option<usize>,
}

impl MatSpec {
    pub fn grey(name: &str, rho: f32) -> Self {
        Self {
            name: Some(name.into()),
            base_color: [rho, rho, rho, 1.0],
            emissive: [0.0; 3],
            strength: None,
            double_sided: false,
            base_color_image: None,
        }
    }
}

/// One node with one mesh of one triangle primitive.
#[derive(Clone, Debug)]
pub struct MeshSpec {
    pub node_name: Option<String>,
    pub mesh_name: Option<String>,
    pub positions: Vec<[f32; 3]>,
    pub uvs: Option<Vec<[f32; 2]>>,
    pub indices: Option<Vec<u32>>,
    pub material: Option<usize>,
    /// Column-major 4×4 node matrix.
    pub matrix: Option<[f32; 16]>,
}

impl MeshSpec {
    pub fn new(name: &str, positions: Vec<[f32; 3]>, indices: Vec<u32>, material: usize) -> Self {
        Self {
            node_name: Some(name.into()),
            mesh_name: None,
            positions,
            uvs: None,
            indices: Some(indices),
            material: Some(material),
            matrix: None,
        }
    }
}

/// Builds the glTF JSON and the binary buffer. `buffer_uri`: `Some(uri)` for a
/// `.gltf` with external or data-URI buffer, `None` for a GLB (BIN chunk).
pub fn build(
    meshes: &[MeshSpec],
    mats: &[MatSpec],
    images: &[Vec<u8>],
    buffer_uri: Option<&str>,
) -> (Value, Vec<u8>) {
    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut gl_meshes = Vec::new();
    let mut nodes = Vec::new();
    let mut push_view = |bin: &mut Vec<u8>, bytes: &[u8], target: Option<u32>| -> usize {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        let mut v = json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            v["target"] = json!(t);
        }
        bin.extend_from_slice(bytes);
        views.push(v);
        views.len() - 1
    };
    for (i, m) in meshes.iter().enumerate() {
        let bytes: Vec<u8> = m
            .positions
            .iter()
            .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
            .collect();
        let v = push_view(&mut bin, &bytes, Some(34962));
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for p in &m.positions {
            for c in 0..3 {
                if p[c].is_finite() {
                    lo[c] = lo[c].min(p[c]);
                    hi[c] = hi[c].max(p[c]);
                }
            }
        }
        let finite = lo.iter().chain(&hi).all(|x| x.is_finite());
        let mut acc = json!({"bufferView": v, "componentType": 5126, "count": m.positions.len(), "type": "VEC3"});
        if finite && !m.positions.is_empty() {
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        accessors.push(acc);
        let pos_acc = accessors.len() - 1;
        let mut prim = json!({"attributes": {"POSITION": pos_acc}});
        if let Some(uvs) = &m.uvs {
            let bytes: Vec<u8> = uvs
                .iter()
                .flat_map(|p| p.iter().flat_map(|c| c.to_le_bytes()))
                .collect();
            let v = push_view(&mut bin, &bytes, Some(34962));
            accessors.push(
                json!({"bufferView": v, "componentType": 5126, "count": uvs.len(), "type": "VEC2"}),
            );
            prim["attributes"]["TEXCOORD_0"] = json!(accessors.len() - 1);
        }
        if let Some(ind) = &m.indices {
            let bytes: Vec<u8> = ind.iter().flat_map(|c| c.to_le_bytes()).collect();
            let v = push_view(&mut bin, &bytes, Some(34963));
            accessors.push(json!({"bufferView": v, "componentType": 5125, "count": ind.len(), "type": "SCALAR"}));
            prim["indices"] = json!(accessors.len() - 1);
        }
        if let Some(mat) = m.material {
            prim["material"] = json!(mat);
        }
        let mut mesh = json!({"primitives": [prim]});
        if let Some(n) = &m.mesh_name {
            mesh["name"] = json!(n);
        }
        gl_meshes.push(mesh);
        let mut node = json!({"mesh": i});
        if let Some(n) = &m.node_name {
            node["name"] = json!(n);
        }
        if let Some(mat) = m.matrix {
            node["matrix"] = json!(mat);
        }
        nodes.push(node);
    }
    let mut gl_images = Vec::new();
    for img in images {
        let v = push_view(&mut bin, img, None);
        gl_images.push(json!({"bufferView": v, "mimeType": "image/png"}));
    }
    let materials: Vec<Value> = mats
        .iter()
        .map(|m| {
            let mut v = json!({
                "pbrMetallicRoughness": {"baseColorFactor": m.base_color, "metallicFactor": 0.0},
                "emissiveFactor": m.emissive,
                "doubleSided": m.double_sided,
            });
            if let Some(n) = &m.name {
                v["name"] = json!(n);
            }
            if let Some(s) = m.strength {
                v["extensions"] =
                    json!({"KHR_materials_emissive_strength": {"emissiveStrength": s}});
            }
            if let Some(i) = m.base_color_image {
                v["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": i, "texCoord": 0});
            }
            v
        })
        .collect();
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let mut buffer = json!({"byteLength": bin.len()});
    if let Some(uri) = buffer_uri {
        buffer["uri"] = json!(uri);
    }
    let mut root = json!({
        "asset": {"version": "2.0", "generator": "wavelux-scene tests"},
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": (0..meshes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": gl_meshes,
        "materials": materials,
        "buffers": [buffer],
        "bufferViews": views,
        "accessors": accessors,
    });
    if !gl_images.is_empty() {
        root["images"] = json!(gl_images);
        root["textures"] = json!(
            (0..gl_images.len())
                .map(|i| json!({"source": i}))
                .collect::<Vec<_>>()
        );
    }
    (root, bin)
}

/// Standard base64 (RFC 4648) for data URIs.
pub fn base64(data: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in data.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for k in 0..4 {
            if k <= chunk.len() {
                out.push(T[((n >> (18 - 6 * k)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// A self-contained `.gltf` JSON text (buffer as a data URI).
pub fn gltf_embedded(meshes: &[MeshSpec], mats: &[MatSpec], images: &[Vec<u8>]) -> String {
    let (mut root, bin) = build(meshes, mats, images, Some(""));
    root["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64(&bin)
    ));
    serde_json::to_string_pretty(&root).expect("serialise")
}

/// A binary glTF (GLB) file.
pub fn glb(meshes: &[MeshSpec], mats: &[MatSpec], images: &[Vec<u8>]) -> Vec<u8> {
    let (root, mut bin) = build(meshes, mats, images, None);
    let mut json = serde_json::to_vec(&root).expect("serialise");
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// A `w × h` RGB8 PNG.
pub fn png_rgb8(w: u32, h: u32, pixels: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut out, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut wr = enc.write_header().expect("png header");
        wr.write_image_data(pixels).expect("png data");
    }
    out
}

/// Two triangles of a unit square in the plane z = 0 (front +z), scaled.
pub fn unit_square(s: f32) -> (Vec<[f32; 3]>, Vec<u32>) {
    (
        vec![[0.0, 0.0, 0.0], [s, 0.0, 0.0], [s, s, 0.0], [0.0, s, 0.0]],
        vec![0, 1, 2, 0, 2, 3],
    )
}
