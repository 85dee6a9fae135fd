//! wavelux-scene: the scene model, its loaders and the built-in scenes.
//!
//! - [`scene`]: [`Scene`], [`Surface`] (exact [`Shape`] + [`Material`] +
//!   [`Sidedness`]), media, cameras, method defaults;
//! - [`material`]: Lambertian reflectance and emission (RGB, optionally textured),
//!   Ward parameters (Glossy §6) and directional emitters;
//! - [`shape`]: triangles, parallelograms, triangle meshes with exact parallelogram
//!   merging, complex polygons with arcs and holes (VirtualMesh §3.2), Bézier patches;
//! - [`light`]: punctual point and spot lights (glTF `KHR_lights_punctual` falloff);
//! - [`group`]: mesh grouping — connected coplanar triangles become the complex
//!   polygons they tile, so a meshed wall, disk or floor with holes is one surface,
//!   and closed meshes that tessellate a sphere become that sphere ([`fit`]);
//! - [`medium`]: voxel grids of opacity (grey), source and albedo (RGB) (GlobalCube
//!   §2.1, §3.1), raw `f32` grid files;
//! - [`gltf_load`]: glTF 2.0 (`.gltf`, `.glb`) loader; [`gltf_write`]: the GLB writer
//!   of scenes made of triangles, parallelograms and meshes; [`gltf_medium`]: the
//!   loader's node extension `WAVELUX_medium`;
//! - [`native`]: the native TOML format (documented in `docs/scene-format.md`);
//! - [`analytic`]: trimmed analytic patches on `wavelux-param`'s equal-area maps;
//! - [`builtin`]: Cornell box, Ziegler §4.1.1 and §4.2.1 scenes, white furnace, and
//!   the VirtualMesh §6 scenes by name;
//! - [`meshless_scenes`]: the meshless method's scenes (atrium, leak rooms, closed
//!   sphere);
//! - [`volume_scenes`]: the Global Cube's participating-medium scenes (`gc-lounge`,
//!   `gc-entrance`, GlobalCube §5) at any `2^k` resolution;
//! - [`virtual_mesh`]: VirtualMesh §6's test scenes — architecture (complex polygons),
//!   quadric teapot, chess set;
//! - [`tessellated`]: their tessellated baselines (VirtualMesh §6.1–6.2);
//! - [`office`]: a furnished office of 343 surfaces lit by one tube in a louvred
//!   luminaire (the larger benchmark of the speed–accuracy report);
//! - [`fixtures`]: scenes as tessellating exporters write them (disks in rings, a UV
//!   sphere, the Cornell box with one surface per face), for measuring mesh grouping.
//!
//! # Radiometric conventions
//!
//! Surfaces are Lambertian (unless a Ward lobe is attached for glossy methods).
//! [`Material::emission`] is the emitted radiant **exitance** `E` in W/m² per RGB
//! channel (radiance `E/π`), and radiosity satisfies `B = E + ρ·H`. glTF's
//! `emissiveFactor × KHR_materials_emissive_strength` is read as emitted radiance and
//! converted with `E = π × emissive`; the native format states `E` directly. One
//! convention for every loader.
//!
//! A one-sided surface reflects and emits on its front only and its back is a black
//! occluder; a two-sided surface has two independent sides.

// reason: `!(x > 0.0)` is the idiom that also rejects NaN, which input validation needs.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod analytic;
pub mod builtin;
pub mod camera;
pub mod error;
pub mod fit;
pub mod fixtures;
pub mod gltf_load;
pub mod gltf_medium;
pub mod gltf_ward;
pub mod gltf_write;
pub mod group;
pub mod light;
pub mod material;
pub mod medium;
pub mod meshless_scenes;
pub mod native;
pub mod office;
pub mod scene;
pub mod shape;
pub mod tessellated;
pub mod virtual_mesh;
pub mod volume_scenes;

use std::path::Path;

pub use analytic::{AnalyticPatch, AnalyticSurface, Placement, Region};
pub use camera::{Camera, Projection};
pub use error::{SceneError, Warning, WarningKind};
pub use gltf_load::{GltfOptions, load_gltf, load_gltf_slice};
pub use gltf_write::{to_glb, write_glb};
pub use group::{Grouped, MeshGrouping, MeshPart, group_mesh, reversed_sides};
pub use light::{Light, LightKind};
pub use material::{
    EmissionProfile, Material, ReflectancePolicy, Rgb, Texture, TextureRef, WardParams,
};
pub use medium::Medium;
pub use native::{load_native, load_native_with, parse_native, parse_native_with};
pub use scene::{DefaultValue, MaterialId, Scene, Sidedness, Surface};
pub use shape::{
    BezierPatch, Loop, LoopEdge, MeshElement, PlaneFrame, PolygonShape, Shape, TriangleMesh,
};
pub use tessellated::{TessellateOptions, primitive_count, tessellated};

/// Options shared by the loaders.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LoadOptions {
    /// How triangle meshes (glTF primitives, native `mesh` surfaces) become surfaces.
    pub grouping: MeshGrouping,
}

/// Loads a scene file, choosing the loader by extension: `.gltf`/`.glb` (glTF 2.0 with
/// default [`GltfOptions`]) or `.toml` (native format).
pub fn load(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
    load_with(path, &LoadOptions::default())
}

/// [`load`] with loader options.
pub fn load_with(path: impl AsRef<Path>, options: &LoadOptions) -> Result<Scene, SceneError> {
    let path = path.as_ref();
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("gltf" | "glb") => load_gltf(
            path,
            &GltfOptions {
                grouping: options.grouping,
                ..GltfOptions::default()
            },
        ),
        Some("toml") => load_native_with(path, options),
        _ => Err(SceneError::UnknownFormat {
            file: path.display().to_string(),
        }),
    }
}
