//! Built-in scenes: the Cornell box, Ziegler's "Unoccluded"/"Occluded" scenes
//! (Ziegler §4.1.1, after Gortler et al. 1993), Ziegler's box scenes with and without
//! the inner cube (Ziegler §4.2.1, Figs. 4.10–4.11) at the high and low reflectance
//! tables, and a closed cube for white-furnace checks.
//!
//! These scenes are data: native-format files in `crates/scene/data/builtin/`
//! ([`BUILTIN_FILES`], embedded at compile time) read by the same loader as a user's
//! file ([`crate::native::parse_native`]); loading a file from that folder with
//! `wavelux solve` gives the built-in scene. Only the parameters the paper varies (the
//! §4.2.1 reflectance table, the furnace's `E` and `ρ`) are applied in code. The scene
//! families with size parameters (VirtualMesh §6, meshless, volume, office) stay small
//! builders in their own modules. Ziegler's figures did not survive the text
//! conversion, so the §4.1/§4.2 geometry is rebuilt from the text: the choices we made
//! are marked "(ours)" in the files and in `docs/scene-format.md`.

use glam::{DVec2, DVec3};

use crate::LoadOptions;
use crate::error::{BUILTIN_FILE, SceneError};
use crate::group::MeshGrouping;
use crate::material::Rgb;
use crate::native::parse_native_with;
use crate::scene::{Scene, Sidedness, Surface};
use crate::shape::{Loop, PlaneFrame, PolygonShape, Shape, TriangleMesh};

/// The built-in scenes' native-format files (`crates/scene/data/builtin/`), embedded:
/// `(file name, text)`.
pub const BUILTIN_FILES: &[(&str, &str)] = &[
    (
        "cornell-box.toml",
        include_str!("../data/builtin/cornell-box.toml"),
    ),
    (
        "ziegler-unoccluded.toml",
        include_str!("../data/builtin/ziegler-unoccluded.toml"),
    ),
    (
        "ziegler-occluded.toml",
        include_str!("../data/builtin/ziegler-occluded.toml"),
    ),
    (
        "ziegler-box.toml",
        include_str!("../data/builtin/ziegler-box.toml"),
    ),
    (
        "ziegler-box-cube.toml",
        include_str!("../data/builtin/ziegler-box-cube.toml"),
    ),
    (
        "white-furnace.toml",
        include_str!("../data/builtin/white-furnace.toml"),
    ),
];

/// Parses the embedded built-in file `file` (one of [`BUILTIN_FILES`]) with the native
/// loader, meshes kept as given ([`MeshGrouping::Triangles`]: a built-in mesh is one
/// surface, its quads merged into parallelograms where exact); errors name it
/// `builtin:<file>`. `wavelux solve <file> --mesh-grouping triangles` loads the same
/// scene from `crates/scene/data/builtin/`.
///
/// # Errors
/// [`SceneError::Io`] for a name not in [`BUILTIN_FILES`]; otherwise the loader's
/// errors (none for the shipped files: the scene crate's tests load every one).
pub fn load_builtin_file(file: &str) -> Result<Scene, SceneError> {
    let label = format!("builtin:{file}");
    let (_, text) = BUILTIN_FILES
        .iter()
        .find(|(name, _)| *name == file)
        .ok_or_else(|| SceneError::Io {
            file: label.clone(),
            message: "no such built-in file".into(),
        })?;
    let options = LoadOptions {
        grouping: MeshGrouping::Triangles,
    };
    parse_native_with(text, &label, None, &options)
}

/// An embedded file that the tests load: failing here is a defect of this crate's
/// data, not of a user's input.
fn embedded(file: &str) -> Scene {
    match load_builtin_file(file) {
        Ok(s) => s,
        Err(e) => panic!("built-in scene file {file} does not load: {e}"),
    }
}

pub(crate) fn one_sided(scene: &mut Scene, name: &str, shape: Shape, material: usize) {
    scene.add_surface(Surface {
        name: name.into(),
        shape,
        material,
        sides: Sidedness::OneSided,
    });
}

/// A planar quad (corners in boundary order) as a two-triangle mesh; the pair merges
/// into one parallelogram when the quad is an exact parallelogram.
pub(crate) fn quad_mesh(quads: &[[[f64; 3]; 4]], scale: f64) -> Shape {
    let mut positions = Vec::new();
    let mut tris = Vec::new();
    for q in quads {
        let base = positions.len() as u32;
        positions.extend(q.iter().map(|p| DVec3::from_array(*p) * scale));
        tris.push([base, base + 1, base + 2]);
        tris.push([base, base + 2, base + 3]);
    }
    // The data below is finite and non-degenerate, so the build cannot fail.
    match TriangleMesh::build(positions, Vec::new(), &tris, BUILTIN_FILE, "quad mesh") {
        Ok(b) => Shape::Mesh(b.mesh),
        Err(_) => Shape::Mesh(TriangleMesh::default()),
    }
}

/// An axis-aligned rectangle with a rectangular hole, as a polygon in the plane
/// `frame`; coordinates are 2D frame coordinates.
pub(crate) fn rect_with_hole(frame: PlaneFrame, outer: [DVec2; 2], hole: [DVec2; 2]) -> Shape {
    let rect =
        |[a, b]: [DVec2; 2]| Loop::polygon(&[a, DVec2::new(b.x, a.y), b, DVec2::new(a.x, b.y)]);
    Shape::Polygon(PolygonShape {
        frame,
        outer: rect(outer),
        holes: vec![rect(hole)],
    })
}

// ---------------------------------------------------------------------------------
// Cornell box
// ---------------------------------------------------------------------------------

/// Millimetres to metres.
pub(crate) const MM: f64 = 1e-3;

/// The Cornell box measured geometry (Cornell University Program of Computer
/// Graphics, "Cornell Box Data", <https://www.graphics.cornell.edu/online/box/data.html>),
/// in millimetres, each quad counter-clockwise seen from its front (inside the box for
/// walls, outside for blocks). The ceiling (556 × 559.2 at `y = 548.8`) and the light
/// are built separately (see [`cornell_box`]). [`cornell_box`] reads the same numbers
/// in metres from `cornell-box.toml`; these constants serve the one-surface-per-face
/// variant [`crate::fixtures::cornell_faces`], and a test checks that they agree.
pub(crate) const CORNELL_FLOOR: [[f64; 3]; 4] = [
    [552.8, 0.0, 0.0],
    [0.0, 0.0, 0.0],
    [0.0, 0.0, 559.2],
    [549.6, 0.0, 559.2],
];
pub(crate) const CORNELL_BACK: [[f64; 3]; 4] = [
    [549.6, 0.0, 559.2],
    [0.0, 0.0, 559.2],
    [0.0, 548.8, 559.2],
    [556.0, 548.8, 559.2],
];
/// Right wall (green), seen from the camera.
pub(crate) const CORNELL_RIGHT: [[f64; 3]; 4] = [
    [0.0, 0.0, 559.2],
    [0.0, 0.0, 0.0],
    [0.0, 548.8, 0.0],
    [0.0, 548.8, 559.2],
];
/// Left wall (red), seen from the camera.
pub(crate) const CORNELL_LEFT: [[f64; 3]; 4] = [
    [552.8, 0.0, 0.0],
    [549.6, 0.0, 559.2],
    [556.0, 548.8, 559.2],
    [556.0, 548.8, 0.0],
];
pub(crate) const CORNELL_SHORT_BLOCK: [[[f64; 3]; 4]; 5] = [
    [
        [130.0, 165.0, 65.0],
        [82.0, 165.0, 225.0],
        [240.0, 165.0, 272.0],
        [290.0, 165.0, 114.0],
    ],
    [
        [290.0, 0.0, 114.0],
        [290.0, 165.0, 114.0],
        [240.0, 165.0, 272.0],
        [240.0, 0.0, 272.0],
    ],
    [
        [130.0, 0.0, 65.0],
        [130.0, 165.0, 65.0],
        [290.0, 165.0, 114.0],
        [290.0, 0.0, 114.0],
    ],
    [
        [82.0, 0.0, 225.0],
        [82.0, 165.0, 225.0],
        [130.0, 165.0, 65.0],
        [130.0, 0.0, 65.0],
    ],
    [
        [240.0, 0.0, 272.0],
        [240.0, 165.0, 272.0],
        [82.0, 165.0, 225.0],
        [82.0, 0.0, 225.0],
    ],
];
pub(crate) const CORNELL_TALL_BLOCK: [[[f64; 3]; 4]; 5] = [
    [
        [423.0, 330.0, 247.0],
        [265.0, 330.0, 296.0],
        [314.0, 330.0, 456.0],
        [472.0, 330.0, 406.0],
    ],
    [
        [423.0, 0.0, 247.0],
        [423.0, 330.0, 247.0],
        [472.0, 330.0, 406.0],
        [472.0, 0.0, 406.0],
    ],
    [
        [472.0, 0.0, 406.0],
        [472.0, 330.0, 406.0],
        [314.0, 330.0, 456.0],
        [314.0, 0.0, 456.0],
    ],
    [
        [314.0, 0.0, 456.0],
        [314.0, 330.0, 456.0],
        [265.0, 330.0, 296.0],
        [265.0, 0.0, 296.0],
    ],
    [
        [265.0, 0.0, 296.0],
        [265.0, 330.0, 296.0],
        [423.0, 330.0, 247.0],
        [423.0, 0.0, 247.0],
    ],
];
/// Ceiling extent in x and z (mm) at height 548.8.
pub(crate) const CORNELL_CEILING: [f64; 3] = [556.0, 548.8, 559.2];
/// Light: x ∈ [213, 343], z ∈ [227, 332] (mm), at the ceiling height.
pub(crate) const CORNELL_LIGHT: [[f64; 2]; 2] = [[213.0, 227.0], [343.0, 332.0]];

/// White (floor, ceiling, back wall, blocks) diffuse reflectance, as in the widely
/// used RGB conversion of the measured spectra (B. Bitterli, "Rendering resources",
/// 2016, scene `cornell-box`).
pub const CORNELL_WHITE: Rgb = Rgb::new(0.725, 0.71, 0.68);
/// Red (left) wall reflectance (same source).
pub const CORNELL_RED: Rgb = Rgb::new(0.63, 0.065, 0.05);
/// Green (right) wall reflectance (same source).
pub const CORNELL_GREEN: Rgb = Rgb::new(0.14, 0.45, 0.091);
/// Light radiance (same source); the light's exitance is `π ×` this.
pub const CORNELL_LIGHT_RADIANCE: Rgb = Rgb::new(17.0, 12.0, 4.0);
/// Light's own diffuse reflectance (same source).
pub const CORNELL_LIGHT_REFLECTANCE: Rgb = Rgb::grey(0.78);

/// The Cornell box in metres, loaded from `data/builtin/cornell-box.toml` (measured
/// data, see the constants' source): floor, back,
/// left (red) and right (green) walls and the two blocks as triangle-pair meshes (the
/// measured quads are not all exact parallelograms; those that are merge into one
/// parallelogram each), the ceiling as a 556 × 559.2 mm polygon with a hole where the
/// 130 × 105 mm light is, and the light as a downward-facing parallelogram filling
/// that hole (the published data puts the light in the ceiling plane; cutting the hole
/// avoids coincident surfaces). One camera: eye (278, 273, −800) mm looking along +z,
/// vertical field of view `2·atan(12.5/35)` (35 mm lens, 25 mm film).
pub fn cornell_box() -> Scene {
    embedded("cornell-box.toml")
}

// ---------------------------------------------------------------------------------
// Ziegler §4.1.1: "Unoccluded" and "Occluded"
// ---------------------------------------------------------------------------------

/// Receiver reflectance `ρ₀ = 0.4` of both §4.1 scenes (Ziegler Figs. 4.1, 4.2).
pub const ZIEGLER_RHO0: f64 = 0.4;
/// Emission `e₁ = 100` of the §4.1 light sources (Ziegler Figs. 4.1, 4.2), taken as
/// exitance `E` (Ziegler's radiosity `u` has the emission `e` added directly).
pub const ZIEGLER_EMISSION: f64 = 100.0;
/// Side of the "Unoccluded" emitter (ours).
pub const UNOCCLUDED_EMITTER_SIDE: f64 = 0.25;
/// Height of the "Unoccluded" emitter above the receiver (ours; "close to" S0).
pub const UNOCCLUDED_EMITTER_HEIGHT: f64 = 0.1;
/// Rotation of the "Unoccluded" emitter and the "Occluded" blocker about the vertical
/// axis, in degrees (ours; "rotated to prevent alignment with the basis functions").
pub const ZIEGLER_ROTATION_DEG: f64 = 30.0;

/// Ziegler §4.1.1 "Unoccluded" (Fig. 4.1, the scene of Gortler et al. 1993): receiver
/// `S0` = unit square `[0,1]² × {0}` facing +z with `ρ₀ = 0.4`; emitter `S1` = square
/// of side 0.25 centred at `(0.5, 0.5, 0.1)`, rotated 30° about z, facing down, with
/// `ρ₁ = 0` and exitance `E = 100`. The reference solution on S0 is
/// `B(p) = ρ₀ E F(p → S1)` (point-to-polygon form factor), Ziegler §4.1.1. Loaded from
/// `data/builtin/ziegler-unoccluded.toml` (the constants above describe it; a test
/// checks that they agree).
pub fn unoccluded() -> Scene {
    embedded("ziegler-unoccluded.toml")
}

/// Side of the "Occluded" blocker (ours).
pub const OCCLUDED_BLOCKER_SIDE: f64 = 0.4;
/// Emitting part of S1 in the "Occluded" scene: `[0.25, 0.75]²` (ours; Fig. 4.2's
/// "indicated area").
pub const OCCLUDED_EMITTER: [[f64; 2]; 2] = [[0.25, 0.25], [0.75, 0.75]];

/// Ziegler §4.1.1 "Occluded" (Fig. 4.2): receiver `S0` = unit square at `z = 0` facing
/// +z, `ρ₀ = 0.4`; `S1` = unit square at `z = 1` facing down, `ρ₁ = 0.4`, emitting
/// `E = 100` in the indicated area, here `[0.25, 0.75]²` (ours); `S1` is therefore
/// two surfaces, `S1` (the square with a hole, no emission) and `S1.emitter` (the
/// hole, `ρ = 0.4`, `E = 100`); blocker `S2` = square of side 0.4 centred at
/// `(0.5, 0.5, 0.5)`, rotated 30° about z, facing up, `ρ₂ = 0`, no emission (its back
/// is a black occluder). Loaded from `data/builtin/ziegler-occluded.toml`.
pub fn occluded() -> Scene {
    embedded("ziegler-occluded.toml")
}

// ---------------------------------------------------------------------------------
// Ziegler §4.2.1 box scenes
// ---------------------------------------------------------------------------------

/// Which of Ziegler §4.2.1's two reflectance settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reflectivity {
    /// High reflectivity, `ρ_avg = 0.52`.
    High,
    /// Low reflectivity, `ρ_avg = 0.35`.
    Low,
}

/// The `(a)`/`(b)` alternative of surface `S9` in Ziegler §4.2.1's table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BoxVariant {
    /// `ρ₉ = 0.4`.
    A,
    /// `ρ₉ = 0.8`.
    B,
}

/// Ziegler §4.2.1's reflectance table, verbatim (`None` marks `S9`'s
/// "0.4(a)/0.8(b)" entry):
///
/// | surface | S0 | S1 | S2 | S3 | S4 | S5 | S6 | S7 | S8 | S9 | S10 | S11 |
/// |---|---|---|---|---|---|---|---|---|---|---|---|---|
/// | high ρ | 0.8 | 0.8 | 0.8 | 0.8 | 0.4 | 0.4 | 0.4 | 0.4 | 0.4 | 0.4(a)/0.8(b) | 0.4 | 0 |
/// | low ρ  | 0.4 | 0.4 | 0.4 | 0.4 | 0.2 | 0.2 | 0.4 | 0.4 | 0.4 | 0.4(a)/0.8(b) | 0.4 | 0 |
pub const ZIEGLER_BOX_HIGH: [Option<f64>; 12] = [
    Some(0.8),
    Some(0.8),
    Some(0.8),
    Some(0.8),
    Some(0.4),
    Some(0.4),
    Some(0.4),
    Some(0.4),
    Some(0.4),
    None,
    Some(0.4),
    Some(0.0),
];
/// The low row of Ziegler §4.2.1's table (see [`ZIEGLER_BOX_HIGH`]).
pub const ZIEGLER_BOX_LOW: [Option<f64>; 12] = [
    Some(0.4),
    Some(0.4),
    Some(0.4),
    Some(0.4),
    Some(0.2),
    Some(0.2),
    Some(0.4),
    Some(0.4),
    Some(0.4),
    None,
    Some(0.4),
    Some(0.0),
];

/// Side of the outer box of the §4.2 scenes (ours; the inner cube is "located at
/// position (1, 1, 1)", so we take `[0, 3]³` with the unit cube `[1, 2]³` inside).
pub const ZIEGLER_BOX_SIDE: f64 = 3.0;

/// The reflectance of surface `i` in Ziegler §4.2.1's table.
pub fn ziegler_box_reflectance(i: usize, reflectivity: Reflectivity, variant: BoxVariant) -> f64 {
    let row = match reflectivity {
        Reflectivity::High => ZIEGLER_BOX_HIGH,
        Reflectivity::Low => ZIEGLER_BOX_LOW,
    };
    row.get(i).copied().flatten().unwrap_or(match variant {
        BoxVariant::A => 0.4,
        BoxVariant::B => 0.8,
    })
}

/// Ziegler §4.2.1's box scenes (Figs. 4.10, 4.11). The figures are lost; we rebuild
/// (ours, documented in `docs/scene-format.md`): outer box `[0, 3]³` (y up) with
/// inward-facing faces `S0` (x = 0), `S1` (x = 3), `S2` (z = 0), `S3` (z = 3), `S4`
/// (floor y = 0) and `S5` (ceiling y = 3). The light is "as specified in Figure 4.2":
/// an emitting part `[1, 2]²` (in x, z) of the ceiling with `E = 100`, so `S5` is the
/// ceiling with a hole plus `S5.light` (same reflectance as `S5`). With
/// `inner_cube`, the unit cube `[1, 2]³` ("located at position (1, 1, 1)") adds the
/// outward-facing faces `S6` (x = 1), `S7` (x = 2), `S8` (z = 1), `S9` (z = 2), `S10`
/// (top y = 2) and `S11` (bottom y = 1). Reflectances from the table
/// ([`ZIEGLER_BOX_HIGH`], [`ZIEGLER_BOX_LOW`]). That the no-occlusion scene has six
/// surfaces and the occluded one twelve matches Ziegler's link counts
/// (2 516 580 = 6² × 69 905 and 10 066 320 = 12² × 69 905 potential links, 69 905 =
/// Σ_{l<5} 16^l same-level pairs of a 5-level Haar hierarchy). Loaded from
/// `data/builtin/ziegler-box.toml` (plus `ziegler-box-cube.toml` with `inner_cube`);
/// the reflectances of the chosen table row and variant are applied here.
pub fn ziegler_box(inner_cube: bool, reflectivity: Reflectivity, variant: BoxVariant) -> Scene {
    let mut s = embedded("ziegler-box.toml");
    if inner_cube {
        s.merge(embedded("ziegler-box-cube.toml"), "");
    }
    s.name = format!(
        "ziegler-box-{}-{}-{}",
        if inner_cube { "occluded" } else { "unoccluded" },
        match reflectivity {
            Reflectivity::High => "high",
            Reflectivity::Low => "low",
        },
        match variant {
            BoxVariant::A => "a",
            BoxVariant::B => "b",
        }
    );
    // Materials are named `S<i>` (and `S5.light`, which takes S5's reflectance).
    for m in &mut s.materials {
        let index = m
            .name
            .strip_prefix('S')
            .and_then(|rest| rest.split('.').next().and_then(|i| i.parse::<usize>().ok()));
        if let Some(i) = index {
            m.reflectance = Rgb::grey(ziegler_box_reflectance(i, reflectivity, variant));
        }
    }
    s
}

// ---------------------------------------------------------------------------------
// White furnace
// ---------------------------------------------------------------------------------

/// A closed unit cube `[0, 1]³` of six inward-facing unit squares (`face-x0`,
/// `face-x1`, `face-y0`, `face-y1`, `face-z0`, `face-z1`), all with reflectance `ρ`
/// and exitance `E` (grey). Every form-factor row sums to one, so the exact radiosity
/// is `B = E / (1 − ρ)` everywhere: the white-furnace check. Loaded from
/// `data/builtin/white-furnace.toml` with `E` and `ρ` applied here.
///
/// # Errors
/// [`SceneError::InvalidReflectance`] unless `0 <= ρ < 1`;
/// [`SceneError::InvalidEmission`] unless `E` is finite and `>= 0`.
pub fn white_furnace(emission: f64, reflectance: f64) -> Result<Scene, SceneError> {
    let mut s = embedded("white-furnace.toml");
    for m in &mut s.materials {
        m.reflectance = Rgb::grey(reflectance);
        m.emission = Rgb::grey(emission);
        m.validate(BUILTIN_FILE)?;
    }
    Ok(s)
}

/// Names accepted by [`builtin`].
pub const BUILTIN_NAMES: &[&str] = &[
    "cornell-box",
    "ziegler-unoccluded",
    "ziegler-occluded",
    "ziegler-box-unoccluded-high-a",
    "ziegler-box-unoccluded-high-b",
    "ziegler-box-unoccluded-low-a",
    "ziegler-box-unoccluded-low-b",
    "ziegler-box-occluded-high-a",
    "ziegler-box-occluded-high-b",
    "ziegler-box-occluded-low-a",
    "ziegler-box-occluded-low-b",
    "white-furnace",
    "architecture",
    "quadric-teapot",
    "chess-set",
    "office",
    "atrium",
    "atrium-s",
    "atrium-xl",
    "leak-rooms",
    "closed-sphere",
    "gc-lounge",
    "gc-entrance",
];

/// A built-in scene by name (see [`BUILTIN_NAMES`]; the `gc-` media also as
/// `gc-lounge-<n>`, see [`crate::volume_scenes`]); `white-furnace` uses `E = 1`,
/// `ρ = 0.5`. The VirtualMesh §6 scenes also take parameters and a suffix (see
/// [`crate::virtual_mesh::by_name`]): `architecture-<bays>x<storeys>`,
/// `chess-set-<files>`, and `<scene>-tessellated` for the tessellated baseline.
/// Returns `None` for unknown names.
pub fn builtin(name: &str) -> Option<Scene> {
    if let Some(s) = crate::virtual_mesh::by_name(name) {
        return Some(s);
    }
    if let Some(s) = crate::meshless_scenes::by_name(name) {
        return Some(s);
    }
    if let Some(s) = crate::volume_scenes::by_name(name) {
        return Some(s);
    }
    match name {
        "cornell-box" => Some(cornell_box()),
        "ziegler-unoccluded" => Some(unoccluded()),
        "ziegler-occluded" => Some(occluded()),
        "white-furnace" => white_furnace(1.0, 0.5).ok(),
        "office" => Some(crate::office::office()),
        _ => {
            let rest = name.strip_prefix("ziegler-box-")?;
            let mut parts = rest.split('-');
            let cube = match parts.next()? {
                "unoccluded" => false,
                "occluded" => true,
                _ => return None,
            };
            let refl = match parts.next()? {
                "high" => Reflectivity::High,
                "low" => Reflectivity::Low,
                _ => return None,
            };
            let var = match parts.next()? {
                "a" => BoxVariant::A,
                "b" => BoxVariant::B,
                _ => return None,
            };
            parts.next().is_none().then(|| ziegler_box(cube, refl, var))
        }
    }
}

#[cfg(test)]
mod tests {
    //! The data files against the published numbers and the documented constants
    //! (the constants describe the files; these tests keep the two in agreement).

    use super::*;
    use crate::shape::MeshElement;

    /// Largest coordinate difference allowed between `x mm × 10⁻³` and the decimal
    /// literal `x / 1000` in metres: both round the same real number, so they differ by
    /// at most a few ulps of a value below 1.
    const ULPS: f64 = 1e-15;

    fn close(a: DVec3, b: DVec3) -> bool {
        (a - b).abs().max_element() <= ULPS
    }

    fn elements(shape: &Shape) -> Vec<MeshElement> {
        match shape {
            Shape::Mesh(m) => m.elements().collect(),
            other => panic!("expected a mesh, got {other:?}"),
        }
    }

    fn same_mesh(a: &Shape, b: &Shape) -> bool {
        let (ea, eb) = (elements(a), elements(b));
        ea.len() == eb.len()
            && ea.iter().zip(&eb).all(|(x, y)| match (x, y) {
                (MeshElement::Triangle(p), MeshElement::Triangle(q)) => {
                    p.iter().zip(q).all(|(p, q)| close(*p, *q))
                }
                (
                    MeshElement::Parallelogram {
                        origin: o1,
                        edge_u: u1,
                        edge_v: v1,
                    },
                    MeshElement::Parallelogram {
                        origin: o2,
                        edge_u: u2,
                        edge_v: v2,
                    },
                ) => close(*o1, *o2) && close(*u1, *u2) && close(*v1, *v2),
                _ => false,
            })
    }

    #[test]
    fn files_on_disk_load_as_the_builtins() {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("data/builtin");
        for (name, _) in BUILTIN_FILES {
            let options = LoadOptions {
                grouping: MeshGrouping::Triangles,
            };
            let from_disk = crate::native::load_native_with(dir.join(name), &options).unwrap();
            let embedded = load_builtin_file(name).unwrap();
            assert_eq!(from_disk.surfaces, embedded.surfaces, "{name}");
            assert_eq!(from_disk.materials, embedded.materials, "{name}");
            assert_eq!(from_disk.cameras, embedded.cameras, "{name}");
            assert!(embedded.warnings.is_empty(), "{name}");
        }
        assert!(load_builtin_file("nope.toml").is_err());
    }

    #[test]
    fn cornell_file_matches_the_published_data() {
        let s = cornell_box();
        let shape = |n: &str| &s.surface(n).unwrap().shape;
        for (name, quads) in [
            ("floor", &[CORNELL_FLOOR][..]),
            ("back_wall", &[CORNELL_BACK]),
            ("left_wall", &[CORNELL_LEFT]),
            ("right_wall", &[CORNELL_RIGHT]),
            ("short_block", &CORNELL_SHORT_BLOCK),
            ("tall_block", &CORNELL_TALL_BLOCK),
        ] {
            let want = quad_mesh(quads, MM);
            assert!(
                same_mesh(shape(name), &want),
                "{name}: {:?} vs {:?}",
                elements(shape(name)),
                elements(&want)
            );
        }
        let [cx, cy, cz] = CORNELL_CEILING.map(|v| v * MM);
        let [[lx0, lz0], [lx1, lz1]] = CORNELL_LIGHT.map(|p| p.map(|v| v * MM));
        let Shape::Polygon(ceiling) = shape("ceiling") else {
            panic!("ceiling is a polygon")
        };
        let starts = |l: &Loop| -> Vec<DVec2> { l.edges.iter().map(|e| e.start()).collect() };
        let want_outer = [(0.0, 0.0), (cx, 0.0), (cx, cz), (0.0, cz)];
        let want_hole = [(lx0, lz0), (lx1, lz0), (lx1, lz1), (lx0, lz1)];
        for (got, want) in [
            (starts(&ceiling.outer), &want_outer),
            (starts(&ceiling.holes[0]), &want_hole),
        ] {
            assert_eq!(got.len(), 4);
            for (g, (x, y)) in got.iter().zip(want) {
                assert!((*g - DVec2::new(*x, *y)).abs().max_element() <= ULPS);
            }
        }
        assert!(close(ceiling.frame.origin, DVec3::new(0.0, cy, 0.0)));
        assert_eq!((ceiling.frame.u, ceiling.frame.v), (DVec3::X, DVec3::Z));
        let Shape::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } = shape("light")
        else {
            panic!("light is a parallelogram")
        };
        assert!(close(*origin, DVec3::new(lx0, cy, lz0)));
        assert!(close(*edge_u, DVec3::new(lx1 - lx0, 0.0, 0.0)));
        assert!(close(*edge_v, DVec3::new(0.0, 0.0, lz1 - lz0)));
        let material = |n: &str| &s.materials[s.material_id(n).unwrap()];
        assert_eq!(material("white").reflectance, CORNELL_WHITE);
        assert_eq!(material("red").reflectance, CORNELL_RED);
        assert_eq!(material("green").reflectance, CORNELL_GREEN);
        assert_eq!(material("light").reflectance, CORNELL_LIGHT_REFLECTANCE);
        assert_eq!(
            material("light").emission,
            CORNELL_LIGHT_RADIANCE.scale(std::f64::consts::PI)
        );
        let cam = &s.cameras[0];
        assert!(close(cam.position, DVec3::new(278.0, 273.0, -800.0) * MM));
        assert!(close(cam.forward, DVec3::Z));
        let crate::camera::Projection::Perspective { yfov, aspect } = cam.projection else {
            panic!("perspective camera")
        };
        assert!((yfov - 2.0 * (12.5f64 / 35.0).atan()).abs() <= 1e-15);
        assert_eq!(aspect, Some(1.0));
    }

    /// Centre, side (of a square) and rotation about z in degrees of a parallelogram.
    fn square(shape: &Shape) -> (DVec3, f64, f64) {
        let Shape::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } = shape
        else {
            panic!("expected a parallelogram, got {shape:?}")
        };
        assert!((edge_u.length() - edge_v.length()).abs() < 1e-15);
        assert!(edge_u.dot(*edge_v).abs() < 1e-15);
        let axis = if edge_u.cross(*edge_v).z > 0.0 {
            *edge_u
        } else {
            *edge_v
        };
        let deg = axis.y.atan2(axis.x).to_degrees();
        (*origin + 0.5 * (*edge_u + *edge_v), edge_u.length(), deg)
    }

    #[test]
    fn ziegler_files_match_the_documented_constants() {
        let u = unoccluded();
        let (c, side, deg) = square(&u.surface("S1").unwrap().shape);
        assert!(close(c, DVec3::new(0.5, 0.5, UNOCCLUDED_EMITTER_HEIGHT)));
        assert!((side - UNOCCLUDED_EMITTER_SIDE).abs() < 1e-15);
        assert!((deg - ZIEGLER_ROTATION_DEG).abs() < 1e-12, "{deg}");
        let m = |s: &Scene, n: &str| s.materials[s.material_id(n).unwrap()].clone();
        assert_eq!(m(&u, "S0").reflectance, Rgb::grey(ZIEGLER_RHO0));
        assert_eq!(m(&u, "S1").emission, Rgb::grey(ZIEGLER_EMISSION));
        let o = occluded();
        let (c, side, deg) = square(&o.surface("S2").unwrap().shape);
        assert!(close(c, DVec3::splat(0.5)));
        assert!((side - OCCLUDED_BLOCKER_SIDE).abs() < 1e-15);
        assert!((deg - ZIEGLER_ROTATION_DEG).abs() < 1e-12, "{deg}");
        let Shape::Parallelogram {
            origin,
            edge_u,
            edge_v,
            ..
        } = o.surface("S1.emitter").unwrap().shape
        else {
            panic!("emitter is a parallelogram")
        };
        let [[x0, y0], [x1, y1]] = OCCLUDED_EMITTER;
        assert_eq!(origin, DVec3::new(x0, y0, 1.0));
        assert_eq!(origin + edge_u + edge_v, DVec3::new(x1, y1, 1.0));
        assert_eq!(m(&o, "S1.emitter").emission, Rgb::grey(ZIEGLER_EMISSION));
        let b = ziegler_box(true, Reflectivity::High, BoxVariant::A);
        let side = |n: &str| b.surface(n).unwrap().shape.area();
        assert_eq!(side("S0"), ZIEGLER_BOX_SIDE * ZIEGLER_BOX_SIDE);
    }
}
