//! Exports of a solution: glTF 2.0 with the radiosity baked into per-vertex colours on
//! a tessellation of the element hierarchy, and per-patch lightmap EXRs.
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
