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
//!   On a masked (virtual) support only the real part is written: leaves outside the
//!   mask are skipped, leaves across its boundary are cut along it (the mask's trim
//!   region, arcs flattened to `1e-4` of its size, clipped cell by cell).
//! - Lightmaps: one linear f32 RGBA EXR per patch, `res × res` pixels over the patch's
//!   unit-square support (`s` right, `t` down: row 0 is `t ≈ 0`), RGB = radiosity
//!   (W/m²) at the pixel centre (at its nearest real point where the centre is
//!   virtual), A = the pixel's real fraction.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DVec2, DVec3};
use serde_json::json;
use wavelux_geometry::tessellate::tessellate_polygon;
use wavelux_geometry::{
    ComplexPolygon, Hit, PlaneFrame, Primitive, Ray, TessellationOptions, tessellate,
};
use wavelux_scene::Scene;
use wavelux_solver::{Coverage, Mask, Side, Solution};

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

/// The real part of a masked support as triangles in its mask plane (a CDT of the
/// trim region, arcs flattened to `1e-4` of the region's diagonal), clipped cell by
/// cell by [`clip_to_cell`].
struct RealPart {
    tris: Vec<[DVec2; 3]>,
}

impl RealPart {
    fn new(mask: &Mask) -> Result<Self, RenderError> {
        let geo = |e: wavelux_geometry::GeometryError| RenderError::Scene(e.to_string());
        let frame = PlaneFrame::from_axes(DVec3::ZERO, DVec3::X, DVec3::Y).map_err(geo)?;
        let poly = ComplexPolygon::new(frame, mask.region().clone()).map_err(geo)?;
        let opts = TessellationOptions {
            chord_tolerance: 1e-4,
            min_angle_deg: 0.0,
            ..TessellationOptions::default()
        };
        let m = tessellate_polygon(&poly, &opts)
            .map_err(|e| RenderError::Scene(format!("cannot tessellate a mask: {e}")))?;
        let tris = m
            .indices
            .iter()
            .map(|t| t.map(|i| m.positions[i as usize].truncate()))
            .collect();
        Ok(Self { tris })
    }
}

/// Sutherland–Hodgman: the part of the convex polygon `poly` on the left of the
/// directed line `a → b`.
fn clip_half(poly: &[DVec2], a: DVec2, b: DVec2) -> Vec<DVec2> {
    let d = b - a;
    let side = |p: DVec2| d.perp_dot(p - a);
    let mut out = Vec::with_capacity(poly.len() + 1);
    for k in 0..poly.len() {
        let (p, q) = (poly[k], poly[(k + 1) % poly.len()]);
        let (sp, sq) = (side(p), side(q));
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            out.push(p + (q - p) * (sp / (sp - sq)));
        }
    }
    out
}

/// The real part inside the support cell `[s0,s0+h]×[t0,t0+h]`, as convex polygons
/// in the mask plane (counter-clockwise there).
fn clip_to_cell(mask: &Mask, real: &RealPart, s0: f64, t0: f64, h: f64) -> Vec<Vec<DVec2>> {
    let mut w = [
        mask.to_plane(s0, t0),
        mask.to_plane(s0 + h, t0),
        mask.to_plane(s0 + h, t0 + h),
        mask.to_plane(s0, t0 + h),
    ];
    if (w[1] - w[0]).perp_dot(w[3] - w[0]) < 0.0 {
        w.swap(1, 3);
    }
    let lo = w.iter().fold(DVec2::splat(f64::INFINITY), |a, b| a.min(*b));
    let hi = w
        .iter()
        .fold(DVec2::splat(f64::NEG_INFINITY), |a, b| a.max(*b));
    let mut out = Vec::new();
    for t in &real.tris {
        let tlo = t[0].min(t[1]).min(t[2]);
        let thi = t[0].max(t[1]).max(t[2]);
        if tlo.x > hi.x || tlo.y > hi.y || thi.x < lo.x || thi.y < lo.y {
            continue;
        }
        let mut poly = t.to_vec();
        for k in 0..4 {
            poly = clip_half(&poly, w[k], w[(k + 1) % 4]);
            if poly.len() < 3 {
                break;
            }
        }
        if poly.len() >= 3 {
            out.push(poly);
        }
    }
    out
}

/// One surface's baked mesh under construction.
struct Baker<'a> {
    solution: &'a Solution,
    patch: usize,
    /// The leaf region `(s0, t0, h)` whose polynomial colours the vertices.
    leaf: (f64, f64, f64),
    mesh: &'a mut MeshData,
    /// Largest vertex radiosity of non-emitting patches (the colour scale).
    scale: &'a mut f64,
}

impl Baker<'_> {
    /// Adds a vertex at support coordinates `(s, t)`, coloured by the leaf's radiosity.
    fn vertex(&mut self, s: f64, t: f64) -> u32 {
        let patch = &self.solution.patches[self.patch];
        let (s0, t0, h) = self.leaf;
        let x = patch.support.point(s, t);
        let b = self
            .solution
            .radiosity(self.patch, clamp_into(s, s0, h), clamp_into(t, t0, h));
        if patch.emission.iter().all(|&e| e <= 0.0) {
            *self.scale = self.scale.max(b.iter().copied().fold(0.0, f64::max));
        }
        let (pos, col, _) = &mut *self.mesh;
        pos.push([x.x as f32, x.y as f32, x.z as f32]);
        col.push(b);
        (pos.len() - 1) as u32
    }

    /// The cell `[s0,s0+h]×[t0,t0+h]` as `sub × sub` quads.
    fn grid(&mut self, s0: f64, t0: f64, h: f64, sub: usize) {
        let n = sub + 1;
        let base = self.mesh.0.len() as u32;
        for j in 0..n {
            for i in 0..n {
                self.vertex(
                    s0 + h * i as f64 / sub as f64,
                    t0 + h * j as f64 / sub as f64,
                );
            }
        }
        for j in 0..sub as u32 {
            for i in 0..sub as u32 {
                let a = base + j * n as u32 + i;
                let (b, c, d) = (a + 1, a + n as u32 + 1, a + n as u32);
                self.mesh.2.extend_from_slice(&[a, b, c, a, c, d]);
            }
        }
    }

    /// A convex polygon of the mask plane, fan-triangulated, front side kept.
    fn polygon(&mut self, mask: &Mask, poly: &[DVec2]) {
        let st: Vec<(f64, f64)> = poly.iter().map(|p| mask.from_plane(*p)).collect();
        let area: f64 = (0..st.len())
            .map(|k| {
                let (a, b) = (st[k], st[(k + 1) % st.len()]);
                a.0 * b.1 - a.1 * b.0
            })
            .sum();
        if area == 0.0 {
            return;
        }
        let ids: Vec<u32> = st.iter().map(|&(s, t)| self.vertex(s, t)).collect();
        for k in 1..ids.len() - 1 {
            let (b, c) = if area > 0.0 {
                (ids[k], ids[k + 1])
            } else {
                (ids[k + 1], ids[k])
            };
            self.mesh.2.extend_from_slice(&[ids[0], b, c]);
        }
    }
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
    let h = solution.system().hierarchy();
    // Per surface: positions, colours (radiosity), indices.
    let mut per: Vec<MeshData> = vec![(Vec::new(), Vec::new(), Vec::new()); names.len()];
    let mut real_parts: HashMap<usize, RealPart> = HashMap::new();
    let mut scale: f64 = 0.0;
    for &leaf in h.leaves() {
        let key = h.keys()[leaf as usize];
        let p = key.patch as usize;
        let patch = &solution.patches[p];
        if patch.side != Side::Front || patch.surface >= per.len() {
            continue;
        }
        let reg = key.region();
        let mut baker = Baker {
            solution,
            patch: p,
            leaf: (reg.s0, reg.t0, reg.h),
            mesh: &mut per[patch.surface],
            scale: &mut scale,
        };
        let Some(mask) = &patch.support.mask else {
            baker.grid(reg.s0, reg.t0, reg.h, sub);
            continue;
        };
        match mask.coverage(reg.s0, reg.t0, reg.h) {
            Coverage::Empty => continue,
            Coverage::Full => baker.grid(reg.s0, reg.t0, reg.h, sub),
            Coverage::Partial => {
                let real = match real_parts.entry(p) {
                    std::collections::hash_map::Entry::Occupied(e) => e.into_mut(),
                    std::collections::hash_map::Entry::Vacant(e) => e.insert(RealPart::new(mask)?),
                };
                let c = reg.h / sub as f64;
                for j in 0..sub {
                    for i in 0..sub {
                        let (s0, t0) = (reg.s0 + c * i as f64, reg.t0 + c * j as f64);
                        match mask.coverage(s0, t0, c) {
                            Coverage::Empty => {}
                            Coverage::Full => baker.grid(s0, t0, c, 1),
                            Coverage::Partial => {
                                for poly in clip_to_cell(mask, real, s0, t0, c) {
                                    baker.polygon(mask, &poly);
                                }
                            }
                        }
                    }
                }
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
/// file-system safe); returns the paths. Pixels are RGBA: `A` is the real fraction of
/// the pixel (exact; `1` everywhere on supports without a mask), RGB the radiosity at
/// the pixel centre, or where the centre is virtual at its nearest real point (so a
/// filtered lookup near the boundary of a masked support never reads the virtual
/// extension).
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
    let px = 1.0 / res as f64;
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
        let mut alpha = vec![1.0; res * res];
        for y in 0..res {
            for x in 0..res {
                let (s, t) = ((x as f64 + 0.5) * px, (y as f64 + 0.5) * px);
                let (s, t) = match &patch.support.mask {
                    Some(mask) => {
                        alpha[y * res + x] = mask.real_fraction(x as f64 * px, y as f64 * px, px);
                        if mask.is_real(s, t) {
                            (s, t)
                        } else {
                            mask.nearest_real(s, t)
                        }
                    }
                    None => (s, t),
                };
                img.pixels[y * res + x] = solution.radiosity(p, s, t);
            }
        }
        img.write_exr_rgba(&alpha, &path)?;
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
    field_at_within(field, prim, x, n, d)
}

/// [`field_at`] with the probe starting `d` above `x` and reaching `d` below it.
fn field_at_within<F: RadiosityField + ?Sized>(
    field: &F,
    prim: usize,
    x: glam::DVec3,
    n: glam::DVec3,
    d: f64,
) -> Option<[f64; 3]> {
    let ray = Ray {
        origin: x + n * d,
        dir: -n,
    };
    let hit: Hit = field.accel().closest_hit(&ray, 0.0, 2.0 * d)?;
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

/// A flat triangle of a primitive: (primitive index, corners, front normal, probe
/// offset).
type Piece = (usize, [glam::DVec3; 3], glam::DVec3, f64);

/// The area-weighted average radiosity (W/m², RGB) of every surface's front side
/// under `field`, in scene order: each primitive is tessellated as in
/// [`write_field_gltf`], each triangle split into `k²` congruent sub-triangles
/// (`k = ⌈√(per_surface / triangles of the surface)⌉`, at most 64) and the field
/// evaluated at their centroids (midpoint rule; exact for fields linear on each
/// sub-triangle). Points the field does not resolve (outside a trim) count as black.
///
/// # Errors
/// [`RenderError::Invalid`] for `per_surface = 0`, [`RenderError::Scene`] for invalid
/// geometry.
pub fn field_surface_averages<F: RadiosityField + ?Sized>(
    field: &F,
    scene: &Scene,
    per_surface: usize,
) -> Result<Vec<[f64; 3]>, RenderError> {
    if per_surface == 0 {
        return Err(invalid("samples per surface", "must be >= 1"));
    }
    let prims = scene
        .primitives(&scene.name)
        .map_err(|e| RenderError::Scene(e.to_string()))?;
    let opts = TessellationOptions::default();
    let diag = field
        .accel()
        .bounds()
        .diagonal()
        .length()
        .max(f64::MIN_POSITIVE);
    // (primitive, triangle, normal, probe offset): flat pieces lie on the primitive;
    // a tessellated curved piece is off it by its chord error, well within 10 % of its
    // longest edge.
    let mut tris: Vec<Vec<Piece>> = vec![Vec::new(); scene.surfaces.len()];
    for (k, (s, prim)) in prims.iter().enumerate() {
        match prim {
            Primitive::Triangle(t) => tris[*s].push((k, t.v, t.normal(), 1e-6 * diag)),
            Primitive::Parallelogram(q) => {
                let c = q.corners();
                tris[*s].push((k, [c[0], c[1], c[2]], q.normal(), 1e-6 * diag));
                tris[*s].push((k, [c[0], c[2], c[3]], q.normal(), 1e-6 * diag));
            }
            other => {
                let m = tessellate(other, &opts).map_err(|e| RenderError::Scene(e.to_string()))?;
                for t in &m.indices {
                    let v = t.map(|i| m.positions[i as usize]);
                    let n = (v[1] - v[0]).cross(v[2] - v[0]).normalize_or_zero();
                    // The primitive's normal orientation, not the winding's.
                    let n0 = m.normals[t[0] as usize];
                    let edge = (0..3)
                        .map(|e| (v[(e + 1) % 3] - v[e]).length())
                        .fold(0.0, f64::max);
                    let d = (0.1 * edge).max(1e-6 * diag);
                    tris[*s].push((k, v, if n.dot(n0) < 0.0 { -n } else { n }, d));
                }
            }
        }
    }
    Ok(tris
        .iter()
        .map(|list| {
            let k = ((per_surface as f64 / list.len().max(1) as f64)
                .sqrt()
                .ceil() as usize)
                .clamp(1, 64);
            let (mut sum, mut area) = ([0.0; 3], 0.0);
            for (prim, v, n, d) in list {
                let a = 0.5 * (v[1] - v[0]).cross(v[2] - v[0]).length();
                if a.is_nan() || a <= 0.0 {
                    continue;
                }
                let w = a / (k * k) as f64;
                let (e1, e2) = ((v[1] - v[0]) / k as f64, (v[2] - v[0]) / k as f64);
                for i in 0..k {
                    for j in 0..k - i {
                        // Upright sub-triangle (i, j) and, where it exists, the inverted one.
                        let base = v[0] + e1 * i as f64 + e2 * j as f64;
                        let mut centroids = vec![base + (e1 + e2) / 3.0];
                        if i + j + 1 < k {
                            centroids.push(base + (e1 + e2) * (2.0 / 3.0));
                        }
                        for c in centroids {
                            let b = field_at_within(field, *prim, c, *n, *d).unwrap_or([0.0; 3]);
                            for (s, v) in sum.iter_mut().zip(b) {
                                *s += w * v;
                            }
                        }
                    }
                }
                area += a;
            }
            if area > 0.0 {
                sum.map(|v| v / area)
            } else {
                [0.0; 3]
            }
        })
        .collect())
}
