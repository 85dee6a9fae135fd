//! The scene model: named surfaces (exact shape + material + sidedness), materials,
//! textures, participating media, cameras and method defaults.
//!
//! Sidedness follows the glTF 2.0 `doubleSided` semantics made radiometric: a
//! one-sided surface reflects and emits only on its front side, and its back is a
//! black occluder (it blocks light but never reflects or emits); a double-sided
//! surface has two *independent* sides, each with its own radiosity unknown and its
//! own material (glTF: the same material on both sides).
//!
//! The model is made to grow without breaking changes: enums are `#[non_exhaustive]`,
//! glossy parameters live in [`crate::Material::ward`], media are separate from
//! surfaces, and meshless methods (Meshless §5.1: they need only ray casting and the
//! local reflectance) read the same surfaces through their shapes and materials.

use std::collections::{BTreeMap, HashSet};

use crate::camera::Camera;
use crate::error::{SceneError, Warning};
use crate::light::Light;
use crate::material::{Material, Texture};
use crate::medium::Medium;
use crate::shape::Shape;

/// Index of a material in [`Scene::materials`].
pub type MaterialId = usize;

/// Which sides of a surface take part in light transport.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum Sidedness {
    /// Only the front side reflects and emits; the back is a black occluder.
    OneSided,
    /// Both sides reflect and emit, independently; the back side uses `back`.
    TwoSided {
        /// Material of the back side.
        back: MaterialId,
    },
}

/// A named surface: exact shape, front material and sidedness.
#[derive(Debug, Clone, PartialEq)]
pub struct Surface {
    /// Unique name within the scene.
    pub name: String,
    /// Exact geometry.
    pub shape: Shape,
    /// Material of the front side.
    pub material: MaterialId,
    /// Sidedness.
    pub sides: Sidedness,
}

/// A value of a method default (from the native format's `[defaults]` table).
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum DefaultValue {
    /// A boolean.
    Bool(bool),
    /// An integer.
    Int(i64),
    /// A float.
    Float(f64),
    /// A string.
    Str(String),
}

/// A complete scene.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scene {
    /// Name of the scene (file stem or built-in name).
    pub name: String,
    /// Surfaces, names unique.
    pub surfaces: Vec<Surface>,
    /// Materials, names unique.
    pub materials: Vec<Material>,
    /// Decoded textures referenced by materials.
    pub textures: Vec<Texture>,
    /// Participating media.
    pub media: Vec<Medium>,
    /// Cameras.
    pub cameras: Vec<Camera>,
    /// Punctual lights (point and spot; [`crate::light`]).
    pub lights: Vec<Light>,
    /// Method defaults (`basis = "multiwavelet"`, `epsilon = 1e-4`, ...), free-form;
    /// the solvers document the keys they read.
    pub defaults: BTreeMap<String, DefaultValue>,
    /// Non-fatal problems found while loading.
    pub warnings: Vec<Warning>,
    /// Surface tangents by surface name: the direction of Ward's `α_x` (Glossy §6.2's
    /// anisotropic reflection), projected onto the tangent plane where it is used. Most
    /// surfaces have none (the glossy method then follows the support's `∂/∂s`). Kept
    /// beside the surfaces rather than in [`Surface`] so that adding it broke no
    /// constructor; [`Scene::tangent`] reads it.
    pub tangents: BTreeMap<String, glam::DVec3>,
}

impl Scene {
    /// An empty scene with a name.
    pub fn new(name: impl Into<String>) -> Self {
        Self {
            name: name.into(),
            ..Self::default()
        }
    }

    /// Adds a material and returns its id. The name is made unique by appending
    /// `#2`, `#3`, ... if needed.
    pub fn add_material(&mut self, mut material: Material) -> MaterialId {
        material.name = unique_name(&material.name, self.materials.iter().map(|m| &m.name));
        self.materials.push(material);
        self.materials.len() - 1
    }

    /// Adds a surface; the name is made unique like [`Scene::add_material`]'s.
    pub fn add_surface(&mut self, mut surface: Surface) {
        surface.name = unique_name(&surface.name, self.surfaces.iter().map(|s| &s.name));
        self.surfaces.push(surface);
    }

    /// The material with this name.
    pub fn material_id(&self, name: &str) -> Option<MaterialId> {
        self.materials.iter().position(|m| m.name == name)
    }

    /// The tangent of surface `index` (see [`Scene::tangents`]).
    pub fn tangent(&self, index: usize) -> Option<glam::DVec3> {
        let s = self.surfaces.get(index)?;
        self.tangents.get(&s.name).copied()
    }

    /// The surface with this name.
    pub fn surface(&self, name: &str) -> Option<&Surface> {
        self.surfaces.iter().find(|s| s.name == name)
    }

    /// Total area of all surfaces (one side each).
    pub fn total_area(&self) -> f64 {
        self.surfaces.iter().map(|s| s.shape.area()).sum()
    }

    /// Total emitted power `Σ area × E` per channel over all emitting sides (W);
    /// textured emission uses the texture mean. Invalid material ids count as black.
    pub fn emitted_power(&self) -> [f64; 3] {
        let mut p = [0.0; 3];
        for s in &self.surfaces {
            let a = s.shape.area();
            let mut add = |m: MaterialId| {
                let Some(mat) = self.materials.get(m) else {
                    return;
                };
                let mut e = mat.emission;
                if let Some(t) = mat
                    .emission_texture
                    .and_then(|t| self.textures.get(t.texture))
                {
                    e = e.times(t.mean());
                }
                for c in 0..3 {
                    p[c] += a * e.0[c];
                }
            };
            add(s.material);
            if let Sidedness::TwoSided { back } = s.sides {
                add(back);
            }
        }
        p
    }

    /// Appends another scene: materials, textures, surfaces, media and cameras, with
    /// `prefix` prepended to every incoming surface, material and medium name; names
    /// that still collide get `#2`, `#3`, ... . Defaults of `self` win; warnings are
    /// concatenated.
    pub fn merge(&mut self, other: Scene, prefix: &str) {
        let tex_base = self.textures.len();
        self.textures.extend(other.textures);
        let mut map = Vec::with_capacity(other.materials.len());
        for mut m in other.materials {
            m.name = format!("{prefix}{}", m.name);
            for t in [&mut m.reflectance_texture, &mut m.emission_texture]
                .into_iter()
                .flatten()
            {
                t.texture += tex_base;
            }
            map.push(self.add_material(m));
        }
        let mut tangents = other.tangents;
        for mut s in other.surfaces {
            let tangent = tangents.remove(&s.name);
            s.name = format!("{prefix}{}", s.name);
            // Ids out of range (an unvalidated scene) stay out of range, so that
            // `validate` still reports them.
            let remap = |id: MaterialId| map.get(id).copied().unwrap_or(usize::MAX);
            s.material = remap(s.material);
            if let Sidedness::TwoSided { back } = &mut s.sides {
                *back = remap(*back);
            }
            self.add_surface(s);
            if let (Some(t), Some(added)) = (tangent, self.surfaces.last()) {
                self.tangents.insert(added.name.clone(), t);
            }
        }
        for mut m in other.media {
            m.name = unique_name(
                &format!("{prefix}{}", m.name),
                self.media.iter().map(|x| &x.name),
            );
            self.media.push(m);
        }
        self.cameras.extend(other.cameras);
        self.lights.extend(other.lights);
        for (k, v) in other.defaults {
            self.defaults.entry(k).or_insert(v);
        }
        self.warnings.extend(other.warnings);
    }

    /// Every surface's exact `wavelux-geometry` primitives, flattened, each with the
    /// index of its surface in [`Scene::surfaces`]. `file` names the scene in errors.
    pub fn primitives(
        &self,
        file: &str,
    ) -> Result<Vec<(usize, wavelux_geometry::Primitive)>, SceneError> {
        let mut out = Vec::new();
        for (i, s) in self.surfaces.iter().enumerate() {
            let element = format!("surface {:?}", s.name);
            out.extend(
                s.shape
                    .primitives(file, &element)?
                    .into_iter()
                    .map(|p| (i, p)),
            );
        }
        Ok(out)
    }

    /// Validates the whole scene: unique names, material ids in range, material
    /// ranges ([`Material::validate`]), shapes ([`Shape::validate`]), texture
    /// references and media. `file` names the source in errors.
    pub fn validate(&self, file: &str) -> Result<(), SceneError> {
        let mut seen = HashSet::new();
        for m in &self.materials {
            if !seen.insert(m.name.as_str()) {
                return Err(SceneError::DuplicateName {
                    file: file.into(),
                    kind: "material".into(),
                    name: m.name.clone(),
                });
            }
            m.validate(file)?;
            for t in [m.reflectance_texture, m.emission_texture]
                .into_iter()
                .flatten()
            {
                if t.texture >= self.textures.len() {
                    return Err(SceneError::UnknownReference {
                        file: file.into(),
                        element: format!("material {:?}", m.name),
                        kind: "texture".into(),
                        name: t.texture.to_string(),
                    });
                }
            }
        }
        let mut seen = HashSet::new();
        for s in &self.surfaces {
            let element = format!("surface {:?}", s.name);
            if !seen.insert(s.name.as_str()) {
                return Err(SceneError::DuplicateName {
                    file: file.into(),
                    kind: "surface".into(),
                    name: s.name.clone(),
                });
            }
            let mut ids = vec![s.material];
            if let Sidedness::TwoSided { back } = s.sides {
                ids.push(back);
            }
            for id in ids {
                if id >= self.materials.len() {
                    return Err(SceneError::UnknownReference {
                        file: file.into(),
                        element,
                        kind: "material".into(),
                        name: id.to_string(),
                    });
                }
            }
            s.shape.validate(file, &element)?;
        }
        for (name, t) in &self.tangents {
            let element = format!("surface {name:?}");
            if self.surface(name).is_none() {
                return Err(SceneError::UnknownReference {
                    file: file.into(),
                    element: "tangents".into(),
                    kind: "surface".into(),
                    name: name.clone(),
                });
            }
            if !(t.is_finite() && t.length() > 0.0) {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element,
                    what: format!("tangent {t} must be finite and non-zero"),
                });
            }
        }
        let mut seen = HashSet::new();
        for m in &self.media {
            if !seen.insert(m.name.as_str()) {
                return Err(SceneError::DuplicateName {
                    file: file.into(),
                    kind: "medium".into(),
                    name: m.name.clone(),
                });
            }
            m.validate(file)?;
        }
        for l in &self.lights {
            l.validate(file)?;
        }
        Ok(())
    }
}

/// `name` if unused, else `name#2`, `name#3`, ... (the first free one).
pub(crate) fn unique_name<'a>(name: &str, existing: impl Iterator<Item = &'a String>) -> String {
    let taken: HashSet<&str> = existing.map(|s| s.as_str()).collect();
    if !taken.contains(name) {
        return name.to_string();
    }
    (2..)
        .map(|k| format!("{name}#{k}"))
        .find(|n| !taken.contains(n.as_str()))
        .unwrap_or_else(|| name.to_string())
}
