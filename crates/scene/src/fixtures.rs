//! Scenes as a tessellating exporter writes them: surfaces that are one disk, one
//! sphere or one floor with holes, stored as many triangles. They are the inputs on
//! which mesh grouping ([`crate::group`]) is measured and tested: write them with
//! [`crate::gltf_write`] and load them back as a user's glTF file would be.
//!
//! - [`coaxial_disks`]: Howell's C-41 configuration (two coaxial parallel disks) with
//!   each disk a polar grid of `sectors × rings` quads split in two (the innermost
//!   ring's quads have two vertices at the centre and give degenerate triangles, as a
//!   naive polar grid does);
//! - [`closed_sphere`]: a UV sphere (`lon` sectors, `lat` bands, fans at the poles)
//!   facing inwards, every side emitting: a white furnace with `B = E/(1 − ρ)`;
//! - [`cornell_faces`]: the Cornell box with one surface per face from the published
//!   data, the floor with holes under the blocks and the ceiling with a hole for the
//!   light, as complex polygons (tessellate with [`crate::tessellated`] before writing).

use glam::{DVec2, DVec3};

use crate::builtin::{
    CORNELL_BACK, CORNELL_CEILING, CORNELL_FLOOR, CORNELL_GREEN, CORNELL_LEFT, CORNELL_LIGHT,
    CORNELL_LIGHT_RADIANCE, CORNELL_LIGHT_REFLECTANCE, CORNELL_RED, CORNELL_RIGHT,
    CORNELL_SHORT_BLOCK, CORNELL_TALL_BLOCK, CORNELL_WHITE, MM, quad_mesh, rect_with_hole,
};
use crate::camera::Camera;
use crate::error::{MEMORY_FILE, SceneError};
use crate::material::{Material, Rgb};
use crate::scene::{Scene, Sidedness, Surface};
use crate::shape::{Loop, PlaneFrame, PolygonShape, Shape, TriangleMesh};

/// A mesh surface from positions and triangles (degenerate triangles dropped).
fn mesh_surface(
    name: &str,
    positions: Vec<DVec3>,
    tris: &[[u32; 3]],
    material: usize,
) -> Result<Surface, SceneError> {
    let built = TriangleMesh::build(positions, Vec::new(), tris, MEMORY_FILE, name)?;
    Ok(Surface {
        name: name.into(),
        shape: Shape::Mesh(built.mesh),
        material,
        sides: Sidedness::OneSided,
    })
}

/// The triangles of a disk of `radius` around `center` in the plane spanned by the unit
/// vectors `u`, `v` (front side `u × v`): vertices on `rings + 1` circles of radii
/// `k·radius/rings` (`k = 0` all at the centre) at `sectors` angles, every grid quad
/// split into two triangles, `2·sectors·rings` in all (`sectors` of them degenerate).
pub fn ring_disk(
    center: DVec3,
    u: DVec3,
    v: DVec3,
    radius: f64,
    sectors: u32,
    rings: u32,
) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::new();
    for k in 0..=rings {
        let r = radius * f64::from(k) / f64::from(rings);
        for j in 0..sectors {
            let a = std::f64::consts::TAU * f64::from(j) / f64::from(sectors);
            positions.push(center + r * (a.cos() * u + a.sin() * v));
        }
    }
    let id = |k: u32, j: u32| k * sectors + j % sectors;
    let mut tris = Vec::new();
    for k in 0..rings {
        for j in 0..sectors {
            let (a, b, c, d) = (id(k, j), id(k + 1, j), id(k + 1, j + 1), id(k, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    (positions, tris)
}

/// Howell C-41: two coaxial disks of radius `radius` at distance `distance`, each a
/// [`ring_disk`] of `sectors × rings` quads: `emitter` at `z = 0` facing `+z`
/// (`ρ = 0`, exitance `E = 1`), `receiver` at `z = distance` facing `−z` (`ρ = 0.5`).
/// The meshes keep every grid triangle, the degenerate ones included (a loader drops
/// them). For the exact disks the receiver's mean radiosity is `0.5 · F` with `F` =
/// [`coaxial_disk_form_factor`]`(radius, radius, distance)` (0.381966 at distance =
/// radius).
pub fn coaxial_disks(radius: f64, distance: f64, sectors: u32, rings: u32) -> Scene {
    let mut s = Scene::new("coaxial-disks");
    let emit = s.add_material(Material::lambertian("emitter", Rgb::BLACK, Rgb::grey(1.0)));
    let recv = s.add_material(Material::lambertian("receiver", Rgb::grey(0.5), Rgb::BLACK));
    // Kept as the raw grid (degenerate centre triangles included), as an exporter of
    // such a grid would write it.
    let raw = |name: &str, (positions, triangles): (Vec<DVec3>, Vec<[u32; 3]>), material| Surface {
        name: name.into(),
        shape: Shape::Mesh(TriangleMesh {
            positions,
            uv_sets: Vec::new(),
            triangles,
            parallelograms: Vec::new(),
        }),
        material,
        sides: Sidedness::OneSided,
    };
    let d = ring_disk(DVec3::ZERO, DVec3::X, DVec3::Y, radius, sectors, rings);
    s.add_surface(raw("emitter", d, emit));
    let d = ring_disk(
        DVec3::new(0.0, 0.0, distance),
        DVec3::Y,
        DVec3::X,
        radius,
        sectors,
        rings,
    );
    s.add_surface(raw("receiver", d, recv));
    if let Some(c) = Camera::look_at(
        "camera",
        DVec3::new(3.0 * radius, 0.2 * radius, 0.5 * distance),
        DVec3::new(0.0, 0.0, 0.5 * distance),
        DVec3::Z,
        50f64.to_radians(),
        None,
    ) {
        s.cameras.push(c);
    }
    s
}

/// The view factor between two coaxial parallel disks of radii `r1` (from) and `r2`
/// (to) at distance `h` (Howell C-41): with `R1 = r1/h`, `R2 = r2/h`,
/// `X = 1 + (1 + R2²)/R1²`, `F12 = (X − √(X² − 4 (R2/R1)²))/2`.
pub fn coaxial_disk_form_factor(r1: f64, r2: f64, h: f64) -> f64 {
    let (a, b) = (r1 / h, r2 / h);
    let x = 1.0 + (1.0 + b * b) / (a * a);
    0.5 * (x - (x * x - 4.0 * (b / a).powi(2)).sqrt())
}

/// A closed UV sphere of `radius` at the origin, `lon` sectors by `lat` bands (fans at
/// the poles, `2·lon·(lat − 1)` triangles: 5,040 for 72 × 36), facing **inwards**,
/// every triangle with reflectance `rho` and exitance `emission`: a white furnace whose
/// exact radiosity is `emission/(1 − rho)` everywhere.
///
/// # Errors
/// Non-finite or degenerate input ([`SceneError`]).
pub fn closed_sphere(
    radius: f64,
    lon: u32,
    lat: u32,
    rho: f64,
    emission: f64,
) -> Result<Scene, SceneError> {
    let mut s = Scene::new("closed-sphere");
    let m = s.add_material(Material::lambertian(
        "furnace",
        Rgb::grey(rho),
        Rgb::grey(emission),
    ));
    let (positions, tris) = uv_sphere(radius, lon, lat, true);
    s.add_surface(mesh_surface("sphere", positions, &tris, m)?);
    Ok(s)
}

/// Vertices and triangles of a UV sphere (see [`closed_sphere`]); `inward` flips the
/// winding so the front faces the centre.
pub fn uv_sphere(radius: f64, lon: u32, lat: u32, inward: bool) -> (Vec<DVec3>, Vec<[u32; 3]>) {
    use std::f64::consts::{PI, TAU};
    let mut positions = vec![DVec3::new(0.0, 0.0, radius)];
    for k in 1..lat {
        let theta = PI * f64::from(k) / f64::from(lat);
        for j in 0..lon {
            let phi = TAU * f64::from(j) / f64::from(lon);
            positions.push(
                radius
                    * DVec3::new(
                        theta.sin() * phi.cos(),
                        theta.sin() * phi.sin(),
                        theta.cos(),
                    ),
            );
        }
    }
    let south = positions.len() as u32;
    positions.push(DVec3::new(0.0, 0.0, -radius));
    let id = |k: u32, j: u32| 1 + (k - 1) * lon + j % lon;
    let mut tris = Vec::new();
    for j in 0..lon {
        tris.push([0, id(1, j), id(1, j + 1)]);
        tris.push([south, id(lat - 1, j + 1), id(lat - 1, j)]);
    }
    for k in 1..lat - 1 {
        for j in 0..lon {
            let (a, b, c, d) = (id(k, j), id(k + 1, j), id(k + 1, j + 1), id(k, j + 1));
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    if inward {
        for t in &mut tris {
            t.swap(1, 2);
        }
    }
    (positions, tris)
}

/// The Cornell box from the published data (see [`crate::builtin::cornell_box`]) with
/// one surface per face: `floor` (with holes under the two blocks), `ceiling` (with a
/// hole for the light), `light`, `back_wall`, `left_wall`, `right_wall`, and the blocks'
/// faces `short_block.0..4`, `tall_block.0..4` (top first). Floor and ceiling are
/// complex polygons; the rest are quads (two triangles, merged when exact
/// parallelograms).
pub fn cornell_faces() -> Scene {
    let mut s = Scene::new("cornell-faces");
    let white = s.add_material(Material::lambertian("white", CORNELL_WHITE, Rgb::BLACK));
    let red = s.add_material(Material::lambertian("red", CORNELL_RED, Rgb::BLACK));
    let green = s.add_material(Material::lambertian("green", CORNELL_GREEN, Rgb::BLACK));
    let light = s.add_material(Material::lambertian(
        "light",
        CORNELL_LIGHT_REFLECTANCE,
        CORNELL_LIGHT_RADIANCE.scale(std::f64::consts::PI),
    ));
    let mut add = |name: &str, shape: Shape, material: usize| {
        s.add_surface(Surface {
            name: name.into(),
            shape,
            material,
            sides: Sidedness::OneSided,
        });
    };
    // Floor: frame u = +z, v = +x, so u × v = +y (up, into the box); 2D = (z, x).
    let zx = |p: [f64; 3]| DVec2::new(p[2], p[0]) * MM;
    let footprint = |block: &[[[f64; 3]; 4]; 5]| Loop::polygon(&block[0].map(zx));
    add(
        "floor",
        Shape::Polygon(PolygonShape {
            frame: PlaneFrame {
                origin: DVec3::ZERO,
                u: DVec3::Z,
                v: DVec3::X,
            },
            outer: Loop::polygon(&CORNELL_FLOOR.map(zx)),
            holes: vec![
                footprint(&CORNELL_SHORT_BLOCK),
                footprint(&CORNELL_TALL_BLOCK),
            ],
        }),
        white,
    );
    let [cx, cy, cz] = CORNELL_CEILING.map(|v| v * MM);
    let [[lx0, lz0], [lx1, lz1]] = CORNELL_LIGHT.map(|p| p.map(|v| v * MM));
    add(
        "ceiling",
        rect_with_hole(
            PlaneFrame {
                origin: DVec3::new(0.0, cy, 0.0),
                u: DVec3::X,
                v: DVec3::Z,
            },
            [DVec2::ZERO, DVec2::new(cx, cz)],
            [DVec2::new(lx0, lz0), DVec2::new(lx1, lz1)],
        ),
        white,
    );
    add(
        "light",
        Shape::parallelogram(
            DVec3::new(lx0, cy, lz0),
            DVec3::new(lx1 - lx0, 0.0, 0.0),
            DVec3::new(0.0, 0.0, lz1 - lz0),
        ),
        light,
    );
    add("back_wall", quad_mesh(&[CORNELL_BACK], MM), white);
    add("left_wall", quad_mesh(&[CORNELL_LEFT], MM), red);
    add("right_wall", quad_mesh(&[CORNELL_RIGHT], MM), green);
    for (name, block) in [
        ("short_block", &CORNELL_SHORT_BLOCK),
        ("tall_block", &CORNELL_TALL_BLOCK),
    ] {
        for (k, q) in block.iter().enumerate() {
            add(&format!("{name}.{k}"), quad_mesh(&[*q], MM), white);
        }
    }
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
