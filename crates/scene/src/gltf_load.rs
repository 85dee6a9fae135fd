//! glTF 2.0 loader (`.gltf` with external or embedded buffers, and `.glb`).
//!
//! What is read, and how (see `docs/scene-format.md` for the full mapping):
//!
//! - the default scene (else the first, else every root node), with node transforms
//!   composed down the hierarchy in `f64`; a negative-determinant transform flips the
//!   winding so that the front side stays the glTF front side;
//! - every triangle mesh primitive (`TRIANGLES`, `TRIANGLE_STRIP`, `TRIANGLE_FAN`)
//!   becomes a [`TriangleMesh`] (degenerate triangles dropped with a counted warning,
//!   exact parallelogram pairs merged; a primitive with no area left is an error),
//!   whose connected coplanar triangles are grouped into complex polygons
//!   ([`crate::group`], unless [`GltfOptions::grouping`] says otherwise): one
//!   [`Surface`] when the primitive is one polygon or one mesh, else one per polygon
//!   (`.face{k}`) and one for the triangles left over (`.rest`); points and lines are
//!   skipped with a warning; names: node name, else mesh name, else `mesh{m}`, with
//!   `.prim{p}` appended when the mesh has several primitives or no name;
//! - materials: `baseColorFactor.rgb` (× `baseColorTexture`, sRGB-decoded) is the
//!   diffuse reflectance; `emissiveFactor × KHR_materials_emissive_strength`
//!   (× `emissiveTexture`) is an emitted radiance `L`, stored as exitance
//!   `E = π L`; `doubleSided` gives [`Sidedness::TwoSided`] with the same material on
//!   both sides, else [`Sidedness::OneSided`]; metallic/roughness, normal and
//!   occlusion maps have no meaning for Lambertian radiosity and are ignored; a Ward
//!   lobe for glossy transport from `extras.ward` (exact) or `KHR_materials_specular`
//!   (+ `_anisotropy`, `_ior`; approximate), see [`crate::gltf_ward`];
//! - cameras (perspective and orthographic) with their node's world transform;
//! - `KHR_lights_punctual` point and spot lights at their node's world position and
//!   `−z` axis, `color × intensity` read as W/sr (see [`crate::light`]); directional
//!   lights are skipped with a warning and `range` is ignored.
//! - participating media from the node extension `WAVELUX_medium`
//!   ([`crate::gltf_medium`]).
//!
//! Buffers are read with the glTF crate; accessors are decoded here with explicit,
//! checked bounds (sparse and quantised accessors are rejected as unsupported), so
//! that no input can make the loader panic.

use std::collections::HashMap;
use std::path::Path;

use glam::{DMat4, DVec2, DVec3};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use crate::camera::{Camera, Projection};
use crate::error::{MEMORY_FILE, SceneError, Warning, WarningKind};
use crate::group::{MeshGrouping, MeshPart, group_mesh, reversed_sides};
use crate::material::{Material, ReflectancePolicy, Rgb, Texture, TextureRef, srgb_to_linear};
use crate::scene::{MaterialId, Scene, Sidedness, Surface};
use crate::shape::{Shape, TriangleMesh};

/// Options of the glTF loader.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct GltfOptions {
    /// What to do with reflectances outside `[0, 1)` (glTF's default material has
    /// `baseColorFactor = 1`, which is rejected under the default policy).
    pub reflectance_policy: ReflectancePolicy,
    /// Skip decoding textures: materials then keep only their factors (the texture
    /// is recorded as an [`WarningKind::Ignored`] warning).
    pub skip_textures: bool,
    /// How triangle meshes become surfaces: grouped into the polygons they tile (the
    /// default), or kept as triangles ([`MeshGrouping::Triangles`]). Textured meshes
    /// are always kept as triangles (polygons carry no texture coordinates).
    pub grouping: MeshGrouping,
}

/// Supported `extensionsRequired` entries.
const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_lights_punctual",
    "KHR_materials_specular",
    "KHR_materials_anisotropy",
    "KHR_materials_ior",
];

/// Loads a `.gltf` or `.glb` file; external buffers and images are resolved relative
/// to the file's directory.
pub fn load_gltf(path: impl AsRef<Path>, options: &GltfOptions) -> Result<Scene, SceneError> {
    let path = path.as_ref();
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| SceneError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    let base = path.parent().unwrap_or(Path::new("."));
    let mut scene = load_gltf_slice(&bytes, &file, Some(base), options)?;
    if let Some(stem) = path.file_stem().and_then(|s| s.to_str()) {
        scene.name = stem.to_string();
    }
    Ok(scene)
}

/// Loads glTF (JSON or GLB) from memory. `file` names the source in errors and
/// warnings; `base` resolves external `uri`s (with `None`, only `data:` URIs and the
/// GLB binary chunk are available).
pub fn load_gltf_slice(
    bytes: &[u8],
    file: &str,
    base: Option<&Path>,
    options: &GltfOptions,
) -> Result<Scene, SceneError> {
    let gerr = |message: String| SceneError::Gltf {
        file: file.into(),
        message,
    };
    // The glTF crate subtracts the 12-byte header from the GLB's declared length
    // without checking it; reject short declared lengths first.
    if bytes.starts_with(b"glTF") {
        let declared = bytes
            .get(8..12)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]) as usize);
        match declared {
            Some(n) if n >= 12 => {}
            _ => return Err(gerr("GLB header declares a length below 12 bytes".into())),
        }
    }
    let (json, blob): (&[u8], Option<Vec<u8>>) = if bytes.starts_with(b"glTF") {
        let glb = gltf::Glb::from_slice(bytes).map_err(|e| gerr(e.to_string()))?;
        let json = match glb.json {
            std::borrow::Cow::Borrowed(b) => b,
            std::borrow::Cow::Owned(_) => return Err(gerr("unexpected GLB layout".into())),
        };
        (json, glb.bin.map(|b| b.into_owned()))
    } else {
        (bytes, None)
    };
    let root: gltf::json::Root =
        gltf::json::deserialize::from_slice(json).map_err(|e| gerr(e.to_string()))?;
    // gltf-json 1.4's validation indexes the POSITION accessor before checking the
    // index; check it here so that validation cannot panic.
    let positions = gltf::json::validation::Checked::Valid(gltf::json::mesh::Semantic::Positions);
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            if let Some(acc) = prim.attributes.get(&positions)
                && acc.value() >= root.accessors.len()
            {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element: format!("mesh {m} primitive {p}"),
                    what: format!("POSITION accessor {} does not exist", acc.value()),
                });
            }
        }
    }
    let document = gltf::Document::from_json(root).map_err(|e| gerr(e.to_string()))?;
    for ext in document.extensions_required() {
        if !SUPPORTED_REQUIRED.contains(&ext) {
            return Err(SceneError::Unsupported {
                file: file.into(),
                element: "extensionsRequired".into(),
                what: format!("required extension {ext}"),
            });
        }
    }
    for (i, b) in document.buffers().enumerate() {
        if let gltf::buffer::Source::Uri(uri) = b.source()
            && base.is_none()
            && !uri.starts_with("data:")
        {
            return Err(SceneError::Unsupported {
                file: file.into(),
                element: format!("buffer {i}"),
                what: format!("external buffer {uri:?} without a base directory"),
            });
        }
    }
    let buffers = gltf::import_buffers(&document, base, blob).map_err(|e| gerr(e.to_string()))?;
    let mut loader = Loader {
        file,
        base,
        options,
        document: &document,
        buffers: &buffers,
        scene: Scene::new(MEMORY_FILE),
        materials: HashMap::new(),
        images: HashMap::new(),
    };
    loader.run()?;
    let scene = loader.scene;
    scene.validate(file)?;
    Ok(scene)
}

struct Loader<'a> {
    file: &'a str,
    base: Option<&'a Path>,
    options: &'a GltfOptions,
    document: &'a gltf::Document,
    buffers: &'a [gltf::buffer::Data],
    scene: Scene,
    /// glTF material index (`None` = default material) → scene material.
    materials: HashMap<Option<usize>, MaterialId>,
    /// (glTF image index, is-reflectance) → scene texture.
    images: HashMap<(usize, bool), usize>,
}

impl<'a> Loader<'a> {
    fn malformed(&self, element: impl Into<String>, what: impl Into<String>) -> SceneError {
        SceneError::Malformed {
            file: self.file.into(),
            element: element.into(),
            what: what.into(),
        }
    }

    fn unsupported(&self, element: impl Into<String>, what: impl Into<String>) -> SceneError {
        SceneError::Unsupported {
            file: self.file.into(),
            element: element.into(),
            what: what.into(),
        }
    }

    fn warn(&mut self, element: impl Into<String>, kind: WarningKind) {
        self.scene.warnings.push(Warning {
            file: self.file.into(),
            element: element.into(),
            kind,
        });
    }

    fn run(&mut self) -> Result<(), SceneError> {
        let doc = self.document;
        let node_count = doc.nodes().count();
        let roots: Vec<usize> = match doc.default_scene().or_else(|| doc.scenes().next()) {
            Some(s) => s.nodes().map(|n| n.index()).collect(),
            None => {
                let mut is_child = vec![false; node_count];
                for n in doc.nodes() {
                    for c in n.children() {
                        is_child[c.index()] = true;
                    }
                }
                (0..node_count).filter(|&i| !is_child[i]).collect()
            }
        };
        let nodes: Vec<gltf::Node<'_>> = doc.nodes().collect();
        let mut visited = vec![false; node_count];
        let mut stack: Vec<(usize, DMat4)> =
            roots.iter().rev().map(|&i| (i, DMat4::IDENTITY)).collect();
        while let Some((i, parent)) = stack.pop() {
            if visited[i] {
                return Err(self.malformed(
                    format!("node {i}"),
                    "node reached twice: the node hierarchy is not a forest (cycle or shared child)",
                ));
            }
            visited[i] = true;
            let node = &nodes[i];
            let local = node.transform().matrix();
            let local = DMat4::from_cols_array_2d(&local.map(|c| c.map(f64::from)));
            for v in local.to_cols_array() {
                if !v.is_finite() {
                    return Err(SceneError::NonFinite {
                        file: self.file.into(),
                        element: format!("node {i}"),
                        what: "transform".into(),
                        value: v,
                    });
                }
            }
            let world = parent * local;
            if let Some(mesh) = node.mesh() {
                self.mesh(node, &mesh, &world)?;
            }
            if let Some(cam) = node.camera() {
                self.camera(node, &cam, &world)?;
            }
            if let Some(light) = node.light() {
                self.light(node, &light, &world)?;
            }
            if let Some(v) = node.extension_value(crate::gltf_medium::EXTENSION) {
                let read = |a: usize, el: &str| self.read_floats(a, el);
                let m = crate::gltf_medium::medium(self.file, i, node.name(), v, &world, &read)?;
                self.scene.media.push(m);
            }
            for c in node.children().collect::<Vec<_>>().into_iter().rev() {
                stack.push((c.index(), world));
            }
        }
        Ok(())
    }

    fn light(
        &mut self,
        node: &gltf::Node<'_>,
        light: &gltf::khr_lights_punctual::Light<'_>,
        world: &DMat4,
    ) -> Result<(), SceneError> {
        use gltf::khr_lights_punctual::Kind;
        let element = format!("light {} (node {})", light.index(), node.index());
        let name = node
            .name()
            .or(light.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("light{}", light.index()));
        let intensity = Rgb(light
            .color()
            .map(|c| f64::from(c) * f64::from(light.intensity())));
        let position = world.transform_point3(DVec3::ZERO);
        let l = match light.kind() {
            Kind::Directional => {
                self.warn(
                    element,
                    WarningKind::Ignored {
                        what: "directional light (only point and spot lights are modelled)".into(),
                    },
                );
                return Ok(());
            }
            Kind::Point => crate::light::Light::point(name, position, intensity),
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let dir = world.transform_vector3(-DVec3::Z);
                crate::light::Light::spot(
                    name,
                    position,
                    dir,
                    f64::from(inner_cone_angle),
                    f64::from(outer_cone_angle),
                    intensity,
                )
            }
        };
        l.validate(self.file).map_err(|e| match e {
            SceneError::Malformed { file, what, .. } => SceneError::Malformed {
                file,
                element: element.clone(),
                what,
            },
            SceneError::NonFinite {
                file, what, value, ..
            } => SceneError::NonFinite {
                file,
                element: element.clone(),
                what,
                value,
            },
            other => other,
        })?;
        self.scene.lights.push(l);
        Ok(())
    }

    fn camera(
        &mut self,
        node: &gltf::Node<'_>,
        cam: &gltf::Camera<'_>,
        world: &DMat4,
    ) -> Result<(), SceneError> {
        let element = format!("camera {} (node {})", cam.index(), node.index());
        let name = node
            .name()
            .or(cam.name())
            .map(str::to_string)
            .unwrap_or_else(|| format!("camera{}", cam.index()));
        let projection = match cam.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov = f64::from(p.yfov());
                if !(yfov > 0.0 && yfov < std::f64::consts::PI) {
                    return Err(self.malformed(element, format!("yfov {yfov} outside (0, π)")));
                }
                let aspect = p.aspect_ratio().map(f64::from);
                if let Some(a) = aspect
                    && !(a.is_finite() && a > 0.0)
                {
                    return Err(self.malformed(element, format!("aspect ratio {a}")));
                }
                Projection::Perspective { yfov, aspect }
            }
            gltf::camera::Projection::Orthographic(o) => {
                let (xmag, ymag) = (f64::from(o.xmag()), f64::from(o.ymag()));
                if !(xmag.is_finite() && ymag.is_finite() && xmag != 0.0 && ymag != 0.0) {
                    return Err(
                        self.malformed(element, "orthographic xmag/ymag zero or not finite")
                    );
                }
                Projection::Orthographic {
                    xmag: xmag.abs(),
                    ymag: ymag.abs(),
                }
            }
        };
        let position = world.transform_point3(DVec3::ZERO);
        let forward = world.transform_vector3(-DVec3::Z).try_normalize();
        let up = world.transform_vector3(DVec3::Y);
        let (Some(forward), true) = (forward, position.is_finite()) else {
            return Err(self.malformed(element, "degenerate camera transform"));
        };
        let Some(up) = (up - forward * forward.dot(up)).try_normalize() else {
            return Err(self.malformed(element, "degenerate camera transform"));
        };
        self.scene.cameras.push(Camera {
            name,
            position,
            forward,
            up,
            projection,
        });
        Ok(())
    }

    fn mesh(
        &mut self,
        node: &gltf::Node<'_>,
        mesh: &gltf::Mesh<'_>,
        world: &DMat4,
    ) -> Result<(), SceneError> {
        let prim_count = mesh.primitives().count();
        let base_name = node.name().or(mesh.name()).map(str::to_string);
        let flip = world.determinant() < 0.0;
        for prim in mesh.primitives() {
            let p = prim.index();
            let element = format!(
                "mesh {} primitive {p} (node {})",
                mesh.index(),
                node.index()
            );
            let name = match &base_name {
                Some(b) if prim_count == 1 => b.clone(),
                Some(b) => format!("{b}.prim{p}"),
                None => format!("mesh{}.prim{p}", mesh.index()),
            };
            let mode = prim.mode();
            if !matches!(
                mode,
                Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
            ) {
                self.warn(
                    element,
                    WarningKind::NonAreaPrimitiveSkipped {
                        mode: format!("{mode:?}"),
                    },
                );
                continue;
            }
            let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
                return Err(self.malformed(element, "primitive has no POSITION attribute"));
            };
            let local = self.read_vec3(&pos_acc, &element)?;
            let positions: Vec<DVec3> = local.iter().map(|x| world.transform_point3(*x)).collect();
            let n = positions.len();
            let indices: Vec<u32> = match prim.indices() {
                Some(acc) => self.read_indices(&acc, &element)?,
                None => {
                    let n32 = u32::try_from(n).map_err(|_| {
                        self.unsupported(element.clone(), "more than 2^32 vertices")
                    })?;
                    (0..n32).collect()
                }
            };
            let mut tris: Vec<[u32; 3]> = match mode {
                Mode::Triangles => indices
                    .chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .collect(),
                Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
                    .map(|i| {
                        let (a, b, c) = (indices[i], indices[i + 1], indices[i + 2]);
                        if i % 2 == 0 { [a, b, c] } else { [b, a, c] }
                    })
                    .collect(),
                _ => (1..indices.len().saturating_sub(1))
                    .map(|i| [indices[0], indices[i], indices[i + 1]])
                    .collect(),
            };
            if flip {
                for t in &mut tris {
                    t.swap(1, 2);
                }
            }
            // Texture coordinates: every TEXCOORD_n set, in order n = 0, 1, ...
            let mut uv_sets = Vec::new();
            while let Some(acc) = prim.get(&gltf::Semantic::TexCoords(uv_sets.len() as u32)) {
                let uv = self.read_uv(&acc, &element)?;
                if uv.len() != n {
                    return Err(self.malformed(
                        element,
                        format!(
                            "TEXCOORD_{} has {} entries for {n} vertices",
                            uv_sets.len(),
                            uv.len()
                        ),
                    ));
                }
                uv_sets.push(uv);
                if uv_sets.len() > 8 {
                    break;
                }
            }
            let build = TriangleMesh::build(positions, uv_sets, &tris, self.file, &element)?;
            if build.dropped > 0 {
                self.warn(
                    element.clone(),
                    WarningKind::DegenerateTrianglesDropped {
                        count: build.dropped,
                    },
                );
            }
            if build.mesh.element_count() == 0 {
                return Err(SceneError::Degenerate {
                    file: self.file.into(),
                    element,
                    what: format!(
                        "all {} triangles have zero area: the surface has zero area",
                        tris.len()
                    ),
                });
            }
            let gmat = prim.material();
            let material = self.material(&gmat, build.mesh.uv_sets.len())?;
            let sides = if gmat.double_sided() {
                Sidedness::TwoSided { back: material }
            } else {
                Sidedness::OneSided
            };
            let m = &self.scene.materials[material];
            let textured = m.reflectance_texture.is_some() || m.emission_texture.is_some();
            let parts = if self.options.grouping == MeshGrouping::Surfaces && !textured {
                let grouped = group_mesh(&build.mesh, self.file, &element)?;
                for w in grouped.warnings {
                    self.warn(element.clone(), w);
                }
                grouped.parts
            } else {
                vec![MeshPart {
                    suffix: String::new(),
                    shape: Shape::Mesh(build.mesh),
                    reversed: false,
                }]
            };
            for part in parts {
                let (material, sides) = if part.reversed {
                    reversed_sides(&mut self.scene, material, sides)
                } else {
                    (material, sides)
                };
                self.scene.add_surface(Surface {
                    name: format!("{name}{}", part.suffix),
                    shape: part.shape,
                    material,
                    sides,
                });
            }
        }
        Ok(())
    }

    /// Bytes of an accessor: `(data, stride, count, element size)`, all bounds checked.
    fn accessor_bytes(
        &self,
        acc: &gltf::Accessor<'_>,
        element: &str,
    ) -> Result<(&'a [u8], usize, usize), SceneError> {
        let what = format!("{element}: accessor {}", acc.index());
        if acc.sparse().is_some() {
            return Err(self.unsupported(what, "sparse accessor"));
        }
        let Some(view) = acc.view() else {
            return Err(self.unsupported(what, "accessor without a buffer view"));
        };
        let size = acc.size();
        let count = acc.count();
        let stride = view.stride().unwrap_or(size);
        if stride < size || size == 0 {
            return Err(self.malformed(
                what,
                format!("byte stride {stride} below element size {size}"),
            ));
        }
        let Some(buf) = self.buffers.get(view.buffer().index()) else {
            return Err(self.malformed(what, "buffer missing"));
        };
        let view_end = view.offset().checked_add(view.length());
        let Some(view_bytes) = view_end.and_then(|e| buf.0.get(view.offset()..e)) else {
            return Err(self.malformed(
                what,
                format!("buffer view {} exceeds its buffer", view.index()),
            ));
        };
        if count == 0 {
            return Ok((&[], stride, 0));
        }
        let end = (count - 1)
            .checked_mul(stride)
            .and_then(|x| x.checked_add(size))
            .and_then(|x| x.checked_add(acc.offset()));
        let Some(data) = end.and_then(|e| view_bytes.get(acc.offset()..e)) else {
            return Err(self.malformed(what, "accessor exceeds its buffer view"));
        };
        Ok((data, stride, count))
    }

    /// A `FLOAT` `SCALAR` or `VEC3` accessor by index: `(values, components)`.
    fn read_floats(&self, index: usize, element: &str) -> Result<(Vec<f64>, usize), SceneError> {
        let Some(acc) = self.document.accessors().nth(index) else {
            return Err(self.malformed(element, format!("accessor {index} does not exist")));
        };
        let comps = match acc.dimensions() {
            Dimensions::Scalar => 1,
            Dimensions::Vec3 => 3,
            _ => 0,
        };
        if comps == 0 || acc.data_type() != DataType::F32 {
            return Err(self.unsupported(
                format!("{element}: accessor {index}"),
                "grids are FLOAT SCALAR or VEC3 accessors",
            ));
        }
        let (data, stride, count) = self.accessor_bytes(&acc, element)?;
        let mut out = Vec::with_capacity(count * comps);
        for k in 0..count {
            for c in 0..comps {
                let o = k * stride + 4 * c;
                let b = &data[o..o + 4];
                out.push(f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])));
            }
        }
        Ok((out, comps))
    }

    fn read_vec3(&self, acc: &gltf::Accessor<'_>, element: &str) -> Result<Vec<DVec3>, SceneError> {
        if acc.dimensions() != Dimensions::Vec3 || acc.data_type() != DataType::F32 {
            return Err(self.unsupported(
                format!("{element}: accessor {}", acc.index()),
                format!(
                    "POSITION as {:?} {:?} (only VEC3 FLOAT)",
                    acc.dimensions(),
                    acc.data_type()
                ),
            ));
        }
        let (data, stride, count) = self.accessor_bytes(acc, element)?;
        let f = |b: &[u8], k: usize| {
            f64::from(f32::from_le_bytes([
                b[4 * k],
                b[4 * k + 1],
                b[4 * k + 2],
                b[4 * k + 3],
            ]))
        };
        Ok((0..count)
            .map(|i| {
                let b = &data[i * stride..i * stride + 12];
                DVec3::new(f(b, 0), f(b, 1), f(b, 2))
            })
            .collect())
    }

    fn read_indices(
        &self,
        acc: &gltf::Accessor<'_>,
        element: &str,
    ) -> Result<Vec<u32>, SceneError> {
        if acc.dimensions() != Dimensions::Scalar
            || !matches!(
                acc.data_type(),
                DataType::U8 | DataType::U16 | DataType::U32
            )
        {
            return Err(self.malformed(
                format!("{element}: accessor {}", acc.index()),
                "indices must be SCALAR unsigned byte/short/int",
            ));
        }
        let (data, stride, count) = self.accessor_bytes(acc, element)?;
        let ty = acc.data_type();
        Ok((0..count)
            .map(|i| {
                let b = &data[i * stride..];
                match ty {
                    DataType::U8 => u32::from(b[0]),
                    DataType::U16 => u32::from(u16::from_le_bytes([b[0], b[1]])),
                    _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
                }
            })
            .collect())
    }

    fn read_uv(&self, acc: &gltf::Accessor<'_>, element: &str) -> Result<Vec<DVec2>, SceneError> {
        let ty = acc.data_type();
        let ok = acc.dimensions() == Dimensions::Vec2
            && (ty == DataType::F32
                || (acc.normalized() && matches!(ty, DataType::U8 | DataType::U16)));
        if !ok {
            return Err(self.unsupported(
                format!("{element}: accessor {}", acc.index()),
                "TEXCOORD must be VEC2 FLOAT or normalized unsigned byte/short",
            ));
        }
        let (data, stride, count) = self.accessor_bytes(acc, element)?;
        Ok((0..count)
            .map(|i| {
                let b = &data[i * stride..];
                let c = |k: usize| match ty {
                    DataType::U8 => f64::from(b[k]) / 255.0,
                    DataType::U16 => {
                        f64::from(u16::from_le_bytes([b[2 * k], b[2 * k + 1]])) / 65535.0
                    }
                    _ => f64::from(f32::from_le_bytes([
                        b[4 * k],
                        b[4 * k + 1],
                        b[4 * k + 2],
                        b[4 * k + 3],
                    ])),
                };
                DVec2::new(c(0), c(1))
            })
            .collect())
    }

    /// Applies the reflectance policy to one value; `element` names the material.
    fn check_reflectance(&mut self, v: f64, element: &str) -> Result<f64, SceneError> {
        if (0.0..1.0).contains(&v) {
            return Ok(v);
        }
        match self.options.reflectance_policy {
            ReflectancePolicy::Clamp { max } if !v.is_nan() => {
                let max = if (0.0..1.0).contains(&max) {
                    max
                } else {
                    0.999
                };
                let to = v.clamp(0.0, max);
                self.warn(element, WarningKind::ReflectanceClamped { from: v, to });
                Ok(to)
            }
            _ => Err(SceneError::InvalidReflectance {
                file: self.file.into(),
                element: element.into(),
                value: v,
            }),
        }
    }

    fn material(
        &mut self,
        m: &gltf::Material<'_>,
        uv_sets: usize,
    ) -> Result<MaterialId, SceneError> {
        if let Some(&id) = self.materials.get(&m.index()) {
            return Ok(id);
        }
        let (name, element) = match m.index() {
            Some(i) => (
                m.name()
                    .map(str::to_string)
                    .unwrap_or_else(|| format!("material{i}")),
                format!("material {i}"),
            ),
            None => ("default".to_string(), "default material".to_string()),
        };
        let pbr = m.pbr_metallic_roughness();
        let [r, g, b, _] = pbr.base_color_factor().map(f64::from);
        let mut refl = [0.0; 3];
        for (k, v) in [r, g, b].into_iter().enumerate() {
            refl[k] = self.check_reflectance(v, &element)?;
        }
        let strength = m.emissive_strength().map_or(1.0, f64::from);
        let emissive = m.emissive_factor().map(|v| f64::from(v) * strength);
        let emission = Rgb(emissive.map(|l| std::f64::consts::PI * l));
        for v in emission.0 {
            if !(v.is_finite() && v >= 0.0) {
                return Err(SceneError::InvalidEmission {
                    file: self.file.into(),
                    element,
                    value: v,
                });
            }
        }
        let mut ignored = Vec::new();
        let ward = crate::gltf_ward::ward_of(m, self.file, &element, &mut |k| ignored.push(k))?;
        for k in ignored {
            self.warn(element.clone(), k);
        }
        if let Some(w) = &ward {
            refl = refl.map(|v| v * w.diffuse_scale);
        }
        let mut material = Material::lambertian(name, Rgb(refl), emission);
        if let Some(w) = ward {
            material.ward = Some(w.ward);
            material.validate(self.file)?;
        }
        if let Some(info) = pbr.base_color_texture() {
            material.reflectance_texture =
                self.texture(&info, true, Rgb(refl), uv_sets, &element)?;
        }
        if let Some(info) = m.emissive_texture()
            && !emission.is_black()
        {
            material.emission_texture = self.texture(&info, false, emission, uv_sets, &element)?;
        }
        let id = self.scene.add_material(material);
        self.materials.insert(m.index(), id);
        Ok(id)
    }

    fn texture(
        &mut self,
        info: &gltf::texture::Info<'_>,
        reflectance: bool,
        factor: Rgb,
        uv_sets: usize,
        element: &str,
    ) -> Result<Option<TextureRef>, SceneError> {
        let image = info.texture().source();
        let what = format!(
            "{element}: {} texture (image {})",
            if reflectance { "baseColor" } else { "emissive" },
            image.index()
        );
        if self.options.skip_textures {
            self.warn(
                what,
                WarningKind::Ignored {
                    what: "texture (skip_textures)".into(),
                },
            );
            return Ok(None);
        }
        if info.tex_coord() as usize >= uv_sets {
            return Err(self.malformed(
                what,
                format!(
                    "uses TEXCOORD_{} which the primitive lacks",
                    info.tex_coord()
                ),
            ));
        }
        let key = (image.index(), reflectance);
        let tex = if let Some(&t) = self.images.get(&key) {
            t
        } else {
            let mut texture = self.decode_image(&image, &what)?;
            if reflectance {
                // factor × texel must stay in [0, 1): apply the policy to the texels.
                let mut worst = 0.0f64;
                for t in &texture.texels {
                    for c in 0..3 {
                        worst = worst.max(t.0[c] * factor.0[c]);
                    }
                }
                if worst >= 1.0 {
                    let max = match self.options.reflectance_policy {
                        ReflectancePolicy::Clamp { max } if (0.0..1.0).contains(&max) => max,
                        ReflectancePolicy::Clamp { .. } => 0.999,
                        ReflectancePolicy::Reject => {
                            return Err(SceneError::InvalidReflectance {
                                file: self.file.into(),
                                element: what,
                                value: worst,
                            });
                        }
                    };
                    for t in &mut texture.texels {
                        for c in 0..3 {
                            if t.0[c] * factor.0[c] > max {
                                t.0[c] = max / factor.0[c];
                            }
                        }
                    }
                    self.warn(
                        what,
                        WarningKind::ReflectanceClamped {
                            from: worst,
                            to: max,
                        },
                    );
                }
            }
            self.scene.textures.push(texture);
            let t = self.scene.textures.len() - 1;
            self.images.insert(key, t);
            t
        };
        Ok(Some(TextureRef {
            texture: tex,
            uv_set: info.tex_coord(),
        }))
    }

    fn decode_image(&self, image: &gltf::Image<'_>, what: &str) -> Result<Texture, SceneError> {
        let name = image
            .name()
            .map(str::to_string)
            .unwrap_or_else(|| format!("image{}", image.index()));
        let base = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let ok = self.buffers.get(view.buffer().index()).is_some_and(|b| {
                    view.offset()
                        .checked_add(view.length())
                        .is_some_and(|e| e <= b.0.len())
                });
                if !ok {
                    return Err(self.malformed(what, "image buffer view exceeds its buffer"));
                }
                // Unused for views, but the glTF crate wants one for data URIs.
                Some(self.base.unwrap_or(Path::new(".")))
            }
            gltf::image::Source::Uri { uri, .. } => {
                if self.base.is_none() && !uri.starts_with("data:") {
                    return Err(self.unsupported(
                        what,
                        format!("external image {uri:?} without a base directory"),
                    ));
                }
                Some(self.base.unwrap_or(Path::new(".")))
            }
        };
        let data = gltf::image::Data::from_source(image.source(), base, self.buffers)
            .map_err(|e| self.malformed(what, format!("cannot decode image: {e}")))?;
        let (w, h) = (data.width as usize, data.height as usize);
        use gltf::image::Format as F;
        let (channels, bytes_per) = match data.format {
            F::R8 => (1, 1),
            F::R8G8 => (2, 1),
            F::R8G8B8 => (3, 1),
            F::R8G8B8A8 => (4, 1),
            F::R16 => (1, 2),
            F::R16G16 => (2, 2),
            F::R16G16B16 => (3, 2),
            F::R16G16B16A16 => (4, 2),
            F::R32G32B32FLOAT => (3, 4),
            F::R32G32B32A32FLOAT => (4, 4),
        };
        let px = channels * bytes_per;
        if w == 0 || h == 0 || data.pixels.len() < w * h * px {
            return Err(self.malformed(what, "image has no pixels"));
        }
        let value = |b: &[u8]| -> f64 {
            match bytes_per {
                1 => srgb_to_linear(f64::from(b[0]) / 255.0),
                2 => srgb_to_linear(f64::from(u16::from_ne_bytes([b[0], b[1]])) / 65535.0),
                _ => f64::from(f32::from_ne_bytes([b[0], b[1], b[2], b[3]])).max(0.0),
            }
        };
        let texels = data.pixels[..w * h * px]
            .chunks_exact(px)
            .map(|p| {
                let ch = |c: usize| value(&p[c * bytes_per..]);
                if channels >= 3 {
                    Rgb([ch(0), ch(1), ch(2)])
                } else {
                    Rgb::grey(ch(0))
                }
            })
            .collect();
        Ok(Texture {
            name,
            width: w,
            height: h,
            texels,
        })
    }
}
