//! glTF 2.0 writer (binary `.glb`) of scenes made of simple shapes: the inverse of
//! [`crate::gltf_load`] for what glTF can say.
//!
//! One node, one mesh and one triangle primitive per surface, named after the surface,
//! with world-space `f32` positions (identity node transforms). Triangles are written as
//! they are, parallelograms as two triangles (the loader merges them back exactly),
//! [`TriangleMesh`]es as their elements. Complex polygons and curved patches must be
//! tessellated first ([`crate::tessellated`]); this writer does not choose a
//! tessellation. Materials: `baseColorFactor` = reflectance, emitted radiance
//! `L = E/π` as `emissiveFactor × KHR_materials_emissive_strength` (strength = the
//! largest channel of `L`, so the factor stays in `[0, 1]`); two-sided surfaces whose
//! back material is the front one are `doubleSided`. Perspective cameras are written
//! with their world transform. A Ward lobe is written exactly as `extras.ward`
//! ([`crate::gltf_ward`] reads it back).
//!
//! What glTF cannot say is an error ([`SceneError::Unsupported`] naming the surface or
//! material), never dropped silently: a different back material, textures,
//! directional emitters, media, punctual lights.

use std::path::Path;

use glam::DVec3;
use serde_json::{Value, json};

use crate::camera::Projection;
use crate::error::SceneError;
use crate::material::EmissionProfile;
use crate::scene::{Scene, Sidedness};
use crate::shape::{MeshElement, Shape};

fn unsupported(file: &str, element: String, what: &str) -> SceneError {
    SceneError::Unsupported {
        file: file.into(),
        element,
        what: what.into(),
    }
}

/// The triangles of a simple shape (`None` for polygons and curved patches).
fn triangles_of(shape: &Shape) -> Option<Vec<[DVec3; 3]>> {
    let quad = |o: DVec3, u: DVec3, v: DVec3| [[o, o + u, o + u + v], [o, o + u + v, o + v]];
    Some(match shape {
        Shape::Triangle(t) => vec![*t],
        Shape::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => quad(*origin, *edge_u, *edge_v).to_vec(),
        Shape::Mesh(m) => m
            .elements()
            .flat_map(|e| match e {
                MeshElement::Triangle(t) => vec![t],
                MeshElement::Parallelogram {
                    origin,
                    edge_u,
                    edge_v,
                } => quad(origin, edge_u, edge_v).to_vec(),
            })
            .collect(),
        _ => return None,
    })
}

/// Appends `bytes` to the binary buffer (4-byte aligned) as a new buffer view.
fn push_view(bin: &mut Vec<u8>, views: &mut Vec<Value>, bytes: &[u8], target: u32) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    views.push(
        json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len(),
                      "target": target}),
    );
    bin.extend_from_slice(bytes);
    views.len() - 1
}

/// The scene as a GLB file (see the module docs). `file` names the destination in
/// errors.
///
/// # Errors
/// [`SceneError::Unsupported`] for a surface that is not a triangle, parallelogram or
/// mesh, a two-sided surface with a different back material, a textured, Ward or
/// directional material, a medium, a punctual light or an orthographic camera;
/// [`SceneError::NonFinite`] for coordinates that do not fit an `f32`.
pub fn to_glb(scene: &Scene, file: &str) -> Result<Vec<u8>, SceneError> {
    if let Some(m) = scene.media.first() {
        return Err(unsupported(
            file,
            format!("medium {:?}", m.name),
            "participating media (glTF has none)",
        ));
    }
    if let Some(l) = scene.lights.first() {
        return Err(unsupported(
            file,
            format!("light {:?}", l.name),
            "punctual lights (this writer has no KHR_lights_punctual)",
        ));
    }
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    let mut materials = Vec::new();
    let mut material_index = vec![None; scene.materials.len()];
    for s in &scene.surfaces {
        let element = format!("surface {:?}", s.name);
        let Some(tris) = triangles_of(&s.shape) else {
            return Err(unsupported(
                file,
                element,
                "polygon or curved surface (tessellate the scene first)",
            ));
        };
        let double = match s.sides {
            Sidedness::TwoSided { back } if back == s.material => true,
            Sidedness::TwoSided { .. } => {
                return Err(unsupported(
                    file,
                    element,
                    "different front and back materials (glTF's doubleSided uses one)",
                ));
            }
            _ => false,
        };
        let Some(mat) = scene.materials.get(s.material) else {
            return Err(SceneError::UnknownReference {
                file: file.into(),
                element,
                kind: "material".into(),
                name: s.material.to_string(),
            });
        };
        let mat_element = format!("material {:?}", mat.name);
        if mat.reflectance_texture.is_some() || mat.emission_texture.is_some() {
            return Err(unsupported(file, mat_element, "textures"));
        }
        if !matches!(mat.emission_profile, EmissionProfile::Lambertian) {
            return Err(unsupported(file, mat_element, "directional emitter"));
        }
        // One glTF material per (scene material, sidedness).
        let key = usize::from(double);
        let index = match material_index[s.material] {
            Some((k, i)) if k == key => i,
            _ => {
                let l = mat.emission.scale(1.0 / std::f64::consts::PI);
                let strength = l.max_channel();
                let factor = if strength > 0.0 {
                    l.scale(1.0 / strength).0
                } else {
                    [0.0; 3]
                };
                let r = mat.reflectance.0;
                let mut m = json!({
                    "name": mat.name,
                    "pbrMetallicRoughness": {"baseColorFactor": [r[0], r[1], r[2], 1.0],
                                             "metallicFactor": 0.0, "roughnessFactor": 1.0},
                    "emissiveFactor": factor,
                    "doubleSided": double,
                });
                if strength > 1.0 {
                    m["extensions"] =
                        json!({"KHR_materials_emissive_strength": {"emissiveStrength": strength}});
                } else if strength > 0.0 {
                    m["emissiveFactor"] = json!(l.0);
                }
                if let Some(w) = &mat.ward {
                    // Exact, read back by `crate::gltf_ward`.
                    m["extras"] = json!({"ward": {"specular": w.specular.0,
                                                  "alpha_x": w.alpha_x, "alpha_y": w.alpha_y}});
                }
                materials.push(m);
                material_index[s.material] = Some((key, materials.len() - 1));
                materials.len() - 1
            }
        };
        let mut pos: Vec<u8> = Vec::with_capacity(36 * tris.len());
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        for (k, p) in tris.iter().flatten().enumerate() {
            let q = p.as_vec3();
            if !q.is_finite() {
                return Err(SceneError::NonFinite {
                    file: file.into(),
                    element,
                    what: format!("vertex {k} as f32"),
                    value: p.max_element(),
                });
            }
            for c in 0..3 {
                lo[c] = lo[c].min(q[c]);
                hi[c] = hi[c].max(q[c]);
                pos.extend_from_slice(&q[c].to_le_bytes());
            }
        }
        let v = push_view(&mut bin, &mut views, &pos, 34962);
        accessors.push(json!({"bufferView": v, "componentType": 5126,
            "count": 3 * tris.len(), "type": "VEC3", "min": lo, "max": hi}));
        meshes.push(json!({"name": s.name, "primitives": [{
            "attributes": {"POSITION": accessors.len() - 1}, "material": index}]}));
        nodes.push(json!({"name": s.name, "mesh": meshes.len() - 1}));
    }
    let mut cameras = Vec::new();
    for c in &scene.cameras {
        let Projection::Perspective { yfov, aspect } = c.projection else {
            return Err(unsupported(
                file,
                format!("camera {:?}", c.name),
                "orthographic camera",
            ));
        };
        let mut p = json!({"yfov": yfov, "znear": 1e-3});
        if let Some(a) = aspect {
            p["aspectRatio"] = json!(a);
        }
        cameras.push(json!({"name": c.name, "type": "perspective", "perspective": p}));
        let (r, u, b) = (c.right(), c.up, -c.forward);
        let t = c.position;
        nodes.push(
            json!({"name": c.name, "camera": cameras.len() - 1, "matrix": [
            r.x, r.y, r.z, 0.0, u.x, u.y, u.z, 0.0, b.x, b.y, b.z, 0.0, t.x, t.y, t.z, 1.0]}),
        );
    }
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": "wavelux-scene"},
        "scene": 0,
        "scenes": [{"name": scene.name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": bin.len()}],
    });
    if !cameras.is_empty() {
        doc["cameras"] = json!(cameras);
    }
    if materials_use_strength(&doc) {
        doc["extensionsUsed"] = json!(["KHR_materials_emissive_strength"]);
    }
    let mut json = serde_json::to_vec(&doc).map_err(|e| SceneError::Gltf {
        file: file.into(),
        message: e.to_string(),
    })?;
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let too_big = |_| unsupported(file, "buffer".into(), "more than 4 GiB");
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    for w in [2, total, json.len()] {
        out.extend_from_slice(&u32::try_from(w).map_err(too_big)?.to_le_bytes());
    }
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&u32::try_from(bin.len()).map_err(too_big)?.to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    Ok(out)
}

fn materials_use_strength(doc: &Value) -> bool {
    doc["materials"]
        .as_array()
        .is_some_and(|m| m.iter().any(|m| m.get("extensions").is_some()))
}

/// Writes [`to_glb`]'s bytes to `path` through a temporary file and a rename, so an
/// existing file is never left half-written.
///
/// # Errors
/// Those of [`to_glb`], and [`SceneError::Io`] on write failures.
pub fn write_glb(scene: &Scene, path: impl AsRef<Path>) -> Result<(), SceneError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let bytes = to_glb(scene, &file)?;
    let io = |e: std::io::Error| SceneError::Io {
        file: file.clone(),
        message: e.to_string(),
    };
    let name = path
        .file_name()
        .ok_or_else(|| SceneError::Io {
            file: file.clone(),
            message: "no file name".into(),
        })?
        .to_string_lossy();
    let tmp = path.with_file_name(format!(".{name}.tmp{}", std::process::id()));
    std::fs::write(&tmp, &bytes).map_err(io)?;
    std::fs::rename(&tmp, path).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        io(e)
    })
}
