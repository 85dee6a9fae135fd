//! Built-in scenes constructed in code (no files): the Cornell box, Ziegler's
//! "Unoccluded"/"Occluded" scenes (Ziegler §4.1.1, after Gortler et al. 1993), Ziegler's
//! box scenes with and without the inner cube (Ziegler §4.2.1, Figs. 4.10–4.11) at the
//! high and low reflectance tables, and a closed cube for white-furnace checks.
//!
//! Every coordinate is documented here and in `docs/scene-format.md`. Ziegler's
//! figures did not survive the text conversion, so the §4.1/§4.2 geometry is rebuilt
//! from the text: the choices we made are marked "(ours)".

use glam::{DVec2, DVec3};

use crate::camera::Camera;
use crate::error::{BUILTIN_FILE, SceneError};
use crate::material::{Material, Rgb};
use crate::scene::{Scene, Sidedness, Surface};
use crate::shape::{Loop, PlaneFrame, PolygonShape, Shape, TriangleMesh};

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
/// are built separately (see [`cornell_box`]).
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

/// The Cornell box in metres (measured data, see the constants' source): floor, back,
/// left (red) and right (green) walls and the two blocks as triangle-pair meshes (the
/// measured quads are not all exact parallelograms; those that are merge into one
/// parallelogram each), the ceiling as a 556 × 559.2 mm polygon with a hole where the
/// 130 × 105 mm light is, and the light as a downward-facing parallelogram filling
/// that hole (the published data puts the light in the ceiling plane; cutting the hole
/// avoids coincident surfaces). One camera: eye (278, 273, −800) mm looking along +z,
/// vertical field of view `2·atan(12.5/35)` (35 mm lens, 25 mm film).
pub fn cornell_box() -> Scene {
    let mut s = Scene::new("cornell-box");
    let white = s.add_material(Material::lambertian("white", CORNELL_WHITE, Rgb::BLACK));
    let red = s.add_material(Material::lambertian("red", CORNELL_RED, Rgb::BLACK));
    let green = s.add_material(Material::lambertian("green", CORNELL_GREEN, Rgb::BLACK));
    let light = s.add_material(Material::lambertian(
        "light",
        CORNELL_LIGHT_REFLECTANCE,
        CORNELL_LIGHT_RADIANCE.scale(std::f64::consts::PI),
    ));
    one_sided(&mut s, "floor", quad_mesh(&[CORNELL_FLOOR], MM), white);
    let [cx, cy, cz] = CORNELL_CEILING.map(|v| v * MM);
    let [[lx0, lz0], [lx1, lz1]] = CORNELL_LIGHT.map(|p| p.map(|v| v * MM));
    // Frame u = +x, v = +z: normal u × v = −y (facing down into the box).
    let ceiling_frame = PlaneFrame {
        origin: DVec3::new(0.0, cy, 0.0),
        u: DVec3::X,
        v: DVec3::Z,
    };
    one_sided(
        &mut s,
        "ceiling",
        rect_with_hole(
            ceiling_frame,
            [DVec2::ZERO, DVec2::new(cx, cz)],
            [DVec2::new(lx0, lz0), DVec2::new(lx1, lz1)],
        ),
        white,
    );
    one_sided(&mut s, "back_wall", quad_mesh(&[CORNELL_BACK], MM), white);
    one_sided(&mut s, "left_wall", quad_mesh(&[CORNELL_LEFT], MM), red);
    one_sided(&mut s, "right_wall", quad_mesh(&[CORNELL_RIGHT], MM), green);
    one_sided(
        &mut s,
        "short_block",
        quad_mesh(&CORNELL_SHORT_BLOCK, MM),
        white,
    );
    one_sided(
        &mut s,
        "tall_block",
        quad_mesh(&CORNELL_TALL_BLOCK, MM),
        white,
    );
    one_sided(
        &mut s,
        "light",
        Shape::parallelogram(
            DVec3::new(lx0, cy, lz0),
            DVec3::new(lx1 - lx0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, lz1 - lz0),
        ),
        light,
    );
    if let Some(cam) = Camera::look_at(
        "camera",
        DVec3::new(278.0, 273.0, -800.0) * MM,
        DVec3::new(278.0, 273.0, -799.0) * MM,
        DVec3::Y,
        2.0 * (12.5f64 / 35.0).atan(),
        Some(1.0),
    ) {
        s.cameras.push(cam);
    }
    s
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

/// A square of side `side` centred at `center` in a horizontal plane, rotated by
/// `deg` about +z, facing `up` (+z) or down (−z).
fn rotated_square(center: DVec3, side: f64, deg: f64, up: bool) -> Shape {
    let (sn, cs) = deg.to_radians().sin_cos();
    let a = DVec3::new(cs, sn, 0.0) * side;
    let b = DVec3::new(-sn, cs, 0.0) * side;
    // a × b = +z side².
    let (eu, ev) = if up { (a, b) } else { (b, a) };
    Shape::parallelogram(center - 0.5 * (eu + ev), eu, ev)
}

/// Ziegler §4.1.1 "Unoccluded" (Fig. 4.1, the scene of Gortler et al. 1993): receiver
/// `S0` = unit square `[0,1]² × {0}` facing +z with `ρ₀ = 0.4`; emitter `S1` = square
/// of side 0.25 centred at `(0.5, 0.5, 0.1)`, rotated 30° about z, facing down, with
/// `ρ₁ = 0` and exitance `E = 100`. The reference solution on S0 is
/// `B(p) = ρ₀ E F(p → S1)` (point-to-polygon form factor), Ziegler §4.1.1.
pub fn unoccluded() -> Scene {
    let mut s = Scene::new("ziegler-unoccluded");
    let m0 = s.add_material(Material::lambertian(
        "S0",
        Rgb::grey(ZIEGLER_RHO0),
        Rgb::BLACK,
    ));
    let m1 = s.add_material(Material::lambertian(
        "S1",
        Rgb::BLACK,
        Rgb::grey(ZIEGLER_EMISSION),
    ));
    one_sided(
        &mut s,
        "S0",
        Shape::parallelogram(DVec3::ZERO, DVec3::X, DVec3::Y),
        m0,
    );
    one_sided(
        &mut s,
        "S1",
        rotated_square(
            DVec3::new(0.5, 0.5, UNOCCLUDED_EMITTER_HEIGHT),
            UNOCCLUDED_EMITTER_SIDE,
            ZIEGLER_ROTATION_DEG,
            false,
        ),
        m1,
    );
    s
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
/// is a black occluder).
pub fn occluded() -> Scene {
    let mut s = Scene::new("ziegler-occluded");
    let m0 = s.add_material(Material::lambertian(
        "S0",
        Rgb::grey(ZIEGLER_RHO0),
        Rgb::BLACK,
    ));
    let m1 = s.add_material(Material::lambertian(
        "S1",
        Rgb::grey(ZIEGLER_RHO0),
        Rgb::BLACK,
    ));
    let m1e = s.add_material(Material::lambertian(
        "S1.emitter",
        Rgb::grey(ZIEGLER_RHO0),
        Rgb::grey(ZIEGLER_EMISSION),
    ));
    let m2 = s.add_material(Material::lambertian("S2", Rgb::BLACK, Rgb::BLACK));
    one_sided(
        &mut s,
        "S0",
        Shape::parallelogram(DVec3::ZERO, DVec3::X, DVec3::Y),
        m0,
    );
    // Frame u = +y, v = +x at z = 1: normal (+y) × (+x) = −z. 2D coordinates (y, x).
    let frame = PlaneFrame {
        origin: DVec3::new(0.0, 0.0, 1.0),
        u: DVec3::Y,
        v: DVec3::X,
    };
    let [[e0x, e0y], [e1x, e1y]] = OCCLUDED_EMITTER;
    one_sided(
        &mut s,
        "S1",
        rect_with_hole(
            frame,
            [DVec2::ZERO, DVec2::ONE],
            [DVec2::new(e0y, e0x), DVec2::new(e1y, e1x)],
        ),
        m1,
    );
    one_sided(
        &mut s,
        "S1.emitter",
        Shape::parallelogram(
            DVec3::new(e0x, e0y, 1.0),
            DVec3::new(0.0, e1y - e0y, 0.0),
            DVec3::new(e1x - e0x, 0.0, 0.0),
        ),
        m1e,
    );
    one_sided(
        &mut s,
        "S2",
        rotated_square(
            DVec3::new(0.5, 0.5, 0.5),
            OCCLUDED_BLOCKER_SIDE,
            ZIEGLER_ROTATION_DEG,
            true,
        ),
        m2,
    );
    s
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
/// Σ_{l<5} 16^l same-level pairs of a 5-level Haar hierarchy).
pub fn ziegler_box(inner_cube: bool, reflectivity: Reflectivity, variant: BoxVariant) -> Scene {
    let l = ZIEGLER_BOX_SIDE;
    let name = format!(
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
    let mut s = Scene::new(name);
    let mat = |s: &mut Scene, i: usize, emission: f64, suffix: &str| {
        let rho = ziegler_box_reflectance(i, reflectivity, variant);
        s.add_material(Material::lambertian(
            format!("S{i}{suffix}"),
            Rgb::grey(rho),
            Rgb::grey(emission),
        ))
    };
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    // Outer box, inward normals (edge_u × edge_v points inside).
    let walls: [(DVec3, DVec3, DVec3); 5] = [
        (DVec3::ZERO, y * l, z * l),             // S0: x = 0, normal +x
        (DVec3::new(l, 0.0, 0.0), z * l, y * l), // S1: x = l, normal −x
        (DVec3::ZERO, x * l, y * l),             // S2: z = 0, normal +z
        (DVec3::new(0.0, 0.0, l), y * l, x * l), // S3: z = l, normal −z
        (DVec3::ZERO, z * l, x * l),             // S4: y = 0, normal +y
    ];
    for (i, (o, u, v)) in walls.into_iter().enumerate() {
        let m = mat(&mut s, i, 0.0, "");
        one_sided(&mut s, &format!("S{i}"), Shape::parallelogram(o, u, v), m);
    }
    // S5: ceiling y = l facing down (frame u = +x, v = +z: normal −y), hole [1,2]².
    let m5 = mat(&mut s, 5, 0.0, "");
    let frame = PlaneFrame {
        origin: DVec3::new(0.0, l, 0.0),
        u: x,
        v: z,
    };
    one_sided(
        &mut s,
        "S5",
        rect_with_hole(
            frame,
            [DVec2::ZERO, DVec2::splat(l)],
            [DVec2::splat(1.0), DVec2::splat(2.0)],
        ),
        m5,
    );
    let m5l = mat(&mut s, 5, ZIEGLER_EMISSION, ".light");
    one_sided(
        &mut s,
        "S5.light",
        Shape::parallelogram(DVec3::new(1.0, l, 1.0), x, z),
        m5l,
    );
    if inner_cube {
        let c0 = DVec3::splat(1.0);
        let faces: [(DVec3, DVec3, DVec3); 6] = [
            (c0, z, y),     // S6: x = 1, normal −x
            (c0 + x, y, z), // S7: x = 2, normal +x
            (c0, y, x),     // S8: z = 1, normal −z
            (c0 + z, x, y), // S9: z = 2, normal +z
            (c0 + y, z, x), // S10: y = 2, normal +y
            (c0, x, z),     // S11: y = 1, normal −y
        ];
        for (k, (o, u, v)) in faces.into_iter().enumerate() {
            let i = 6 + k;
            let m = mat(&mut s, i, 0.0, "");
            one_sided(&mut s, &format!("S{i}"), Shape::parallelogram(o, u, v), m);
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
/// is `B = E / (1 − ρ)` everywhere: the white-furnace check.
///
/// # Errors
/// [`SceneError::InvalidReflectance`] unless `0 <= ρ < 1`;
/// [`SceneError::InvalidEmission`] unless `E` is finite and `>= 0`.
pub fn white_furnace(emission: f64, reflectance: f64) -> Result<Scene, SceneError> {
    let mut s = Scene::new("white-furnace");
    let m = s.add_material(Material::lambertian(
        "furnace",
        Rgb::grey(reflectance),
        Rgb::grey(emission),
    ));
    s.materials[m].validate(BUILTIN_FILE)?;
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    let faces = [
        ("face-x0", DVec3::ZERO, y, z),
        ("face-x1", x, z, y),
        ("face-y0", DVec3::ZERO, z, x),
        ("face-y1", y, x, z),
        ("face-z0", DVec3::ZERO, x, y),
        ("face-z1", z, y, x),
    ];
    for (name, o, u, v) in faces {
        one_sided(&mut s, name, Shape::parallelogram(o, u, v), m);
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
