//! Exports of a solution: glTF 2.0 with the radiosity baked into per-vertex colours on
//! a tessellation of the element hierarchy, and per-patch lightmap EXRs; and the same
//! two exports of any [`RadiosityField`] on the scene's exact primitives
//! ([`write_field_gltf`], [`write_field_lightmaps`]: one mesh per surface from the
//! primitives' tessellation, one lightmap per primitive over its unit-square support).
//!
//! - glTF: every leaf element of every front-side patch becomes `sub × sub` quads (two
//!   triangles each) of its support's image; vertices are not shared between leaves,
//!   so the baked colours show the solution exactly as the solver represents it,
//!   discontinuities at element boundaries included. `COLOR_0` holds
//!   `B / B_scale` clamped to `[0, 1]` (glTF colours are linear and displayed in
//!   `[0, 1]`), with `B_scale` the largest vertex radiosity of any non-emitting patch;
//!   the scale is stored in the mesh `extras` (`radiosity_scale_w_per_m2`) so the
//!   physical values can be recovered. One mesh and one node per scene surface, named
//!   after the surface, with the `KHR_materials_unlit` material so viewers show the
//!   baked colours as they are (base colour 0.99, not 1: the file then loads back
//!   through wavelux's own glTF loader, which requires `ρ < 1`).
//! - Lightmaps: one linear f32 EXR per patch, `res × res` pixels over the patch's
//!   unit-square support (`s` right, `t` down: row 0 is `t ≈ 0`), pixel = radiosity
//!   (W/m²) at the pixel centre.

use std::path::{Path, PathBuf};

use serde_json::json;
use wavelux_solver::{Side, Solution};

use wavelux_geometry::{Hit, Primitive, Ray, TessellationOptions, tessellate};
use wavelux_scene::Scene;

use crate::field::RadiosityField;
use crate::image::{Image, write_bytes_atomic};
use crate::{RenderError, invalid};

/// Positions, radiosity per vertex, triangle indices of one surface.
type MeshData = (Vec<[f32; 3]>, Vec<[f64; 3]>, Vec<u32>);

fn clamp_into(v: f64, lo: f64, h: f64) -> f64 {
    let d = 1e-9 * h;
    v.clamp(lo + d, lo + h - d)
}

/// A file-system-safe version of a surface name.
fn safe(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Writes `path` (`.gltf`) and its buffer (`path` with extension `.bin`): the baked
/// tessellation described in the module docs. `names[i]` names surface `i`.
///
/// # Errors
/// [`RenderError::Invalid`] for `sub ∉ 1..=16` or a path without a file name,
/// [`RenderError::Io`] on write failures.
pub fn write_gltf(
    solution: &Solution,
    names: &[String],
    path: &Path,
    sub: usize,
) -> Result<(), RenderError> {
    if !(1..=16).contains(&sub) {
        return Err(invalid("sub", format!("{sub} not in 1..=16")));
    }
    let h = &solution.system.h;
    // Per surface: positions, colours (radiosity), indices.
    let mut per: Vec<MeshData> = vec![(Vec::new(), Vec::new(), Vec::new()); names.len()];
    let mut scale: f64 = 0.0;
    for &leaf in &h.leaves {
        let key = h.keys[leaf as usize];
        let p = key.patch as usize;
        let patch = &solution.patches[p];
        if patch.side != Side::Front || patch.surface >= per.len() {
            continue;
        }
        let reg = key.region();
        let (pos, col, idx) = &mut per[patch.surface];
        let n = sub + 1;
        let base = pos.len() as u32;
        for j in 0..n {
            for i in 0..n {
                let s = reg.s0 + reg.h * i as f64 / sub as f64;
                let t = reg.t0 + reg.h * j as f64 / sub as f64;
                let x = patch.support.point(s, t);
                pos.push([x.x as f32, x.y as f32, x.z as f32]);
                let b = solution.radiosity(
                    p,
                    clamp_into(s, reg.s0, reg.h),
                    clamp_into(t, reg.t0, reg.h),
                );
                if patch.emission.iter().all(|&e| e <= 0.0) {
                    scale = scale.max(b.iter().copied().fold(0.0, f64::max));
                }
                col.push(b);
            }
        }
        for j in 0..sub as u32 {
            for i in 0..sub as u32 {
                let a = base + j * n as u32 + i;
                let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32);
                idx.extend_from_slice(&[a, b, c, a, c, d]);
            }
        }
    }
    let scale = if scale > 0.0 { scale } else { 1.0 };
    write_baked(&per, names, scale, path)
}

/// Writes the glTF (+ `.bin`) of baked meshes: one mesh and node per non-empty entry
/// of `per`, named by `names`, colours `B / scale` (module docs).
fn write_baked(
    per: &[MeshData],
    names: &[String],
    scale: f64,
    path: &Path,
) -> Result<(), RenderError> {
    let file = path
        .file_name()
        .ok_or_else(|| invalid("path", "no file name"))?
        .to_string_lossy()
        .into_owned();
    let bin_path: PathBuf = path.with_extension("bin");
    let bin_name = bin_path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_else(|| format!("{file}.bin"));
    let mut bin: Vec<u8> = Vec::new();
    let (mut views, mut accessors, mut meshes, mut nodes) =
        (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for (si, (pos, col, idx)) in per.iter().enumerate() {
        if idx.is_empty() {
            continue;
        }
        let mut lo = [f32::INFINITY; 3];
        let mut hi = [f32::NEG_INFINITY; 3];
        let off = bin.len();
        for v in pos {
            for c in 0..3 {
                lo[c] = lo[c].min(v[c]);
                hi[c] = hi[c].max(v[c]);
                bin.extend_from_slice(&v[c].to_le_bytes());
            }
        }
        views.push(
            json!({"buffer": 0, "byteOffset": off, "byteLength": bin.len() - off, "target": 34962}),
        );
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
            "count": pos.len(), "type": "VEC3", "min": lo, "max": hi}));
        let pos_acc = accessors.len() - 1;
        let off = bin.len();
        for b in col {
            for c in 0..3 {
                let v = (b[c] / scale).clamp(0.0, 1.0) as f32;
                bin.extend_from_slice(&v.to_le_bytes());
            }
        }
        views.push(
            json!({"buffer": 0, "byteOffset": off, "byteLength": bin.len() - off, "target": 34962}),
        );
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5126,
            "count": col.len(), "type": "VEC3"}));
        let col_acc = accessors.len() - 1;
        let off = bin.len();
        for i in idx {
            bin.extend_from_slice(&i.to_le_bytes());
        }
        views.push(
            json!({"buffer": 0, "byteOffset": off, "byteLength": bin.len() - off, "target": 34963}),
        );
        accessors.push(json!({"bufferView": views.len() - 1, "componentType": 5125,
            "count": idx.len(), "type": "SCALAR"}));
        let idx_acc = accessors.len() - 1;
        meshes.push(json!({
            "name": names[si],
            "primitives": [{"attributes": {"POSITION": pos_acc, "COLOR_0": col_acc},
                            "indices": idx_acc, "material": 0}],
            "extras": {"radiosity_scale_w_per_m2": scale}
        }));
        nodes.push(json!({"name": names[si], "mesh": meshes.len() - 1}));
    }
    let doc = json!({
        "asset": {"version": "2.0", "generator": "wavelux-render"},
        "extensionsUsed": ["KHR_materials_unlit"],
        "buffers": [{"uri": bin_name, "byteLength": bin.len()}],
        "bufferViews": views,
        "accessors": accessors,
        "materials": [{"name": "baked-radiosity", "extensions": {"KHR_materials_unlit": {}},
                       "pbrMetallicRoughness": {"baseColorFactor": [0.99, 0.99, 0.99, 1.0],
                       "metallicFactor": 0.0}}],
        "meshes": meshes,
        "nodes": nodes,
        "scenes": [{"nodes": (0..nodes.len()).collect::<Vec<_>>()}],
        "scene": 0
    });
    let text = serde_json::to_string_pretty(&doc).map_err(|e| RenderError::Io {
        path: path.display().to_string(),
        message: e.to_string(),
    })?;
    write_bytes_atomic(&bin_path, &bin)?;
    write_bytes_atomic(path, text.as_bytes())
}

/// Writes one `res × res` lightmap EXR per patch into `dir`, named
/// `SURFACE.PIECE.exr` (`SURFACE.PIECE.back.exr` for back sides; names made
/// file-system safe); returns the paths.
///
/// # Errors
/// [`RenderError::Invalid`] for `res ∉ 1..=8192`, [`RenderError::Io`] on failures.
pub fn write_lightmaps(
    solution: &Solution,
    names: &[String],
    dir: &Path,
    res: usize,
) -> Result<Vec<PathBuf>, RenderError> {
    if !(1..=8192).contains(&res) {
        return Err(invalid(
            "lightmap resolution",
            format!("{res} not in 1..=8192"),
        ));
    }
    std::fs::create_dir_all(dir).map_err(|e| RenderError::Io {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let mut out = Vec::new();
    for (p, patch) in solution.patches.iter().enumerate() {
        let name = names
            .get(patch.surface)
            .map_or_else(|| format!("surface{}", patch.surface), |n| safe(n));
        let side = if patch.side == Side::Back {
            ".back"
        } else {
            ""
        };
        let path = dir.join(format!("{name}.{}{side}.exr", patch.piece));
        let mut img = Image::new(res, res);
        for y in 0..res {
            for x in 0..res {
                let (s, t) = ((x as f64 + 0.5) / res as f64, (y as f64 + 0.5) / res as f64);
                img.pixels[y * res + x] = solution.radiosity(p, s, t);
            }
        }
        img.write_exr(&path)?;
        out.push(path);
    }
    Ok(out)
}

/// The field's radiosity on the front side of primitive `prim` at `x` (normal `n`):
/// a short ray from just above `x` back along `−n` must hit `prim` itself; `None`
/// otherwise (e.g. `x` outside a trimmed region).
fn field_at<F: RadiosityField + ?Sized>(
    field: &F,
    prim: usize,
    x: glam::DVec3,
    n: glam::DVec3,
) -> Option<[f64; 3]> {
    let d = 1e-6
        * field
            .accel()
            .bounds()
            .diagonal()
            .length()
            .max(f64::MIN_POSITIVE);
    let ray = Ray {
        origin: x + n * d,
        dir: -n,
    };
    let hit: Hit = field.accel().closest_hit(&ray, 0.0, 10.0 * d)?;
    if hit.prim as usize != prim || !hit.front {
        return None;
    }
    let p = field.resolve(&hit)?;
    Some(field.radiosity(&p))
}

/// Writes `path` (`.gltf` + `.bin`) with the field's radiosity baked into the vertex
/// colours of a tessellation of every surface's front side (triangles and
/// parallelograms as they are, other primitives by `wavelux-geometry`'s default
/// tessellation; vertices not shared between primitives). `field` must trace the
/// scene's primitives in [`Scene::primitives`] order. Colours and scale as in the
/// module docs.
///
/// # Errors
/// [`RenderError::Scene`] for invalid geometry, [`RenderError::Io`] on write failures.
pub fn write_field_gltf<F: RadiosityField + ?Sized>(
    field: &F,
    scene: &Scene,
    path: &Path,
) -> Result<(), RenderError> {
    let prims = scene
        .primitives(&scene.name)
        .map_err(|e| RenderError::Scene(e.to_string()))?;
    let mut per: Vec<MeshData> = vec![(Vec::new(), Vec::new(), Vec::new()); scene.surfaces.len()];
    let mut scale: f64 = 0.0;
    let opts = TessellationOptions::default();
    for (k, (s, prim)) in prims.iter().enumerate() {
        let (pos, nor, tris): (Vec<glam::DVec3>, Vec<glam::DVec3>, Vec<[u32; 3]>) = match prim {
            Primitive::Triangle(t) => (t.v.to_vec(), vec![t.normal(); 3], vec![[0, 1, 2]]),
            Primitive::Parallelogram(q) => {
                let c = q.corners();
                (c.to_vec(), vec![q.normal(); 4], vec![[0, 1, 2], [0, 2, 3]])
            }
            other => {
                let m = tessellate(other, &opts).map_err(|e| RenderError::Scene(e.to_string()))?;
                (m.positions, m.normals, m.indices)
            }
        };
        let emitter = scene
            .materials
            .get(scene.surfaces[*s].material)
            .is_some_and(|m| m.is_emitter());
        let (vp, vc, vi) = &mut per[*s];
        let base = vp.len() as u32;
        let centroid = pos.iter().copied().sum::<glam::DVec3>() / pos.len().max(1) as f64;
        for (x, n) in pos.iter().zip(&nor) {
            // Vertices sit on edges shared with other primitives: evaluate a hair
            // towards the centroid so that the probe ray hits this primitive.
            let inside = *x + (centroid - *x) * 1e-6;
            let b = field_at(field, k, inside, *n).unwrap_or([0.0; 3]);
            if !emitter {
                scale = scale.max(b.iter().copied().fold(0.0, f64::max));
            }
            vp.push([x.x as f32, x.y as f32, x.z as f32]);
            vc.push(b);
        }
        for t in tris {
            vi.extend(t.iter().map(|i| base + i));
        }
    }
    let names: Vec<String> = scene.surfaces.iter().map(|s| s.name.clone()).collect();
    write_baked(&per, &names, if scale > 0.0 { scale } else { 1.0 }, path)
}

/// Writes one `res × res` lightmap EXR per primitive of the scene into `dir`
/// (`SURFACE.K.exr`, `K` the primitive's index within its surface), pixel = the
/// field's radiosity (W/m²) on the front side at the texel centre of the primitive's
/// unit-square support (black outside a trimmed region); returns the paths.
///
/// # Errors
/// [`RenderError::Invalid`] for `res ∉ 1..=8192`, [`RenderError::Scene`] for invalid
/// geometry, [`RenderError::Io`] on failures.
pub fn write_field_lightmaps<F: RadiosityField + ?Sized>(
    field: &F,
    scene: &Scene,
    dir: &Path,
    res: usize,
) -> Result<Vec<PathBuf>, RenderError> {
    if !(1..=8192).contains(&res) {
        return Err(invalid(
            "lightmap resolution",
            format!("{res} not in 1..=8192"),
        ));
    }
    let prims = scene
        .primitives(&scene.name)
        .map_err(|e| RenderError::Scene(e.to_string()))?;
    std::fs::create_dir_all(dir).map_err(|e| RenderError::Io {
        path: dir.display().to_string(),
        message: e.to_string(),
    })?;
    let mut out = Vec::new();
    let mut count = vec![0usize; scene.surfaces.len()];
    for (k, (s, prim)) in prims.iter().enumerate() {
        let piece = count[*s];
        count[*s] += 1;
        let path = dir.join(format!("{}.{piece}.exr", safe(&scene.surfaces[*s].name)));
        let mut img = Image::new(res, res);
        for y in 0..res {
            for x in 0..res {
                let uv =
                    glam::DVec2::new((x as f64 + 0.5) / res as f64, (y as f64 + 0.5) / res as f64);
                let (p, n) = (prim.eval(uv), prim.normal(uv));
                img.pixels[y * res + x] = field_at(field, k, p, n).unwrap_or([0.0; 3]);
            }
        }
        img.write_exr(&path)?;
        out.push(path);
    }
    Ok(out)
}
