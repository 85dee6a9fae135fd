//! The built-in furnished office (`builtin:office`): a room of 5 × 4 × 2.8 m lit by one
//! fluorescent tube inside a louvred luminaire, with desks, chairs, monitors, a
//! bookshelf with books and a filing cabinet — 343 surfaces. It is the larger
//! benchmark of the speed–accuracy report (issue 12 §1: "one larger scene of at least
//! 200 surfaces"), in the spirit of the classic furnished-office radiosity test scenes
//! (one tube lighting the room through its luminaire), but built here from scratch:
//! every coordinate below is ours.
//!
//! Units are metres, `+z` is up, the room is `[0, 5] × [0, 4] × [0, 2.8]`. Every piece
//! of furniture is made of axis-aligned boxes whose faces are one-sided parallelograms
//! with outward normals; faces resting on the floor or on another box, or hidden
//! against a wall, are left out so that no two surfaces coincide. The luminaire's
//! housing and louvres are two-sided sheets (outside and reflector sides). The walls,
//! floor and ceiling face into the room; the west wall is a rectilinear polygon with a
//! notch where the door is, the east wall a polygon with a rectangular window hole.
//! Light comes only from the tube (a 1.1 m × 3 cm × 3 cm box of exitance
//! `OFFICE_TUBE_EXITANCE`), so everything the room receives passes the housing's
//! opening between the louvres.

use glam::{DVec2, DVec3};

use crate::builtin::{one_sided, rect_with_hole};
use crate::camera::Camera;
use crate::material::{Material, Rgb};
use crate::scene::{MaterialId, Scene, Sidedness, Surface};
use crate::shape::{Loop, PlaneFrame, PolygonShape, Shape};

/// Room extent (m): `[0, x] × [0, y] × [0, z]`.
pub const OFFICE_ROOM: [f64; 3] = [5.0, 4.0, 2.8];
/// Emitted exitance of the tube's faces (W/m², RGB; warm white).
pub const OFFICE_TUBE_EXITANCE: Rgb = Rgb::new(300.0, 290.0, 260.0);
/// Number of surfaces of [`office`] (checked by a test).
pub const OFFICE_SURFACES: usize = 343;

/// Which faces of an axis-aligned box to emit, as outward directions.
#[derive(Debug, Clone, Copy)]
struct Faces {
    lo: [bool; 3],
    hi: [bool; 3],
}

impl Faces {
    const ALL: Faces = Faces {
        lo: [true; 3],
        hi: [true; 3],
    };
    /// Every face but the bottom (`−z`): a box standing on something.
    const NO_BOTTOM: Faces = Faces {
        lo: [true, true, false],
        hi: [true; 3],
    };
    /// The four vertical faces (legs, rods).
    const SIDES: Faces = Faces {
        lo: [true, true, false],
        hi: [true, true, false],
    };

    fn without(mut self, axis: usize, hi: bool) -> Faces {
        if hi {
            self.hi[axis] = false;
        } else {
            self.lo[axis] = false;
        }
        self
    }
}

/// The outward face of the box `[lo, hi]` on `axis` at its `hi` or `lo` end, as a
/// parallelogram whose normal `edge_u × edge_v` points out of the box.
fn box_face(lo: DVec3, hi: DVec3, axis: usize, at_hi: bool) -> Shape {
    let d = hi - lo;
    let e = [DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z];
    // The two other axes in cyclic order: e[a1] × e[a2] points along +axis.
    let (a1, a2) = ((axis + 1) % 3, (axis + 2) % 3);
    if at_hi {
        Shape::parallelogram(lo + e[axis], e[a1], e[a2])
    } else {
        Shape::parallelogram(lo, e[a2], e[a1])
    }
}

const AXIS: [&str; 3] = ["x", "y", "z"];

/// Adds the chosen faces of the box `[lo, hi]` as surfaces `NAME.{-x,+x,...}`
/// (one-sided, or two-sided with the back material).
fn add_box(
    s: &mut Scene,
    name: &str,
    lo: [f64; 3],
    hi: [f64; 3],
    faces: Faces,
    material: MaterialId,
    back: Option<MaterialId>,
) {
    let (lo, hi) = (DVec3::from_array(lo), DVec3::from_array(hi));
    for axis in 0..3 {
        for at_hi in [false, true] {
            let on = if at_hi {
                faces.hi[axis]
            } else {
                faces.lo[axis]
            };
            if !on {
                continue;
            }
            let sign = if at_hi { '+' } else { '-' };
            s.add_surface(Surface {
                name: format!("{name}.{sign}{}", AXIS[axis]),
                shape: box_face(lo, hi, axis, at_hi),
                material,
                sides: back.map_or(Sidedness::OneSided, |b| Sidedness::TwoSided { back: b }),
            });
        }
    }
}

/// Materials of the office.
struct Palette {
    desk: MaterialId,
    metal: MaterialId,
    casing: MaterialId,
    screen: MaterialId,
    shelf: MaterialId,
    books: Vec<MaterialId>,
}

/// A desk: top `[x0, x0 + 1.6] × [3.1, 3.9]` at 0.72–0.75 m on four 5 cm legs, with a
/// monitor on a stand (32 surfaces).
fn desk(s: &mut Scene, name: &str, x0: f64, p: &Palette) {
    let (y0, y1) = (3.1, 3.9);
    let x1 = x0 + 1.6;
    add_box(
        s,
        &format!("{name}.top"),
        [x0, y0, 0.72],
        [x1, y1, 0.75],
        Faces::ALL,
        p.desk,
        None,
    );
    for (k, (lx, ly)) in [(x0 + 0.03, y0 + 0.03), (x1 - 0.08, y0 + 0.03)]
        .into_iter()
        .chain([(x0 + 0.03, y1 - 0.08), (x1 - 0.08, y1 - 0.08)])
        .enumerate()
    {
        add_box(
            s,
            &format!("{name}.leg{k}"),
            [lx, ly, 0.0],
            [lx + 0.05, ly + 0.05, 0.72],
            Faces::SIDES,
            p.metal,
            None,
        );
    }
    let xm = 0.5 * (x0 + x1);
    add_box(
        s,
        &format!("{name}.stand"),
        [xm - 0.05, 3.55, 0.75],
        [xm + 0.05, 3.65, 0.9],
        Faces::NO_BOTTOM.without(2, true),
        p.metal,
        None,
    );
    // The monitor: casing on five faces, the screen facing the room (−y).
    add_box(
        s,
        &format!("{name}.monitor"),
        [xm - 0.275, 3.5, 0.9],
        [xm + 0.275, 3.55, 1.25],
        Faces::ALL.without(1, false),
        p.casing,
        None,
    );
    add_box(
        s,
        &format!("{name}.screen"),
        [xm - 0.275, 3.5, 0.9],
        [xm + 0.275, 3.55, 1.25],
        Faces {
            lo: [false, true, false],
            hi: [false; 3],
        },
        p.screen,
        None,
    );
}

/// A chair: seat 45 × 45 cm at 0.43–0.48 m on four 3 cm legs, a 45 cm backrest on the
/// side `back` (`(axis, hi)`) of the seat (27 surfaces).
fn chair(
    s: &mut Scene,
    name: &str,
    centre: [f64; 2],
    back: (usize, bool),
    fabric: MaterialId,
    metal: MaterialId,
) {
    let h = 0.225;
    let (x0, x1, y0, y1) = (centre[0] - h, centre[0] + h, centre[1] - h, centre[1] + h);
    add_box(
        s,
        &format!("{name}.seat"),
        [x0, y0, 0.43],
        [x1, y1, 0.48],
        Faces::ALL,
        fabric,
        None,
    );
    let (mut lo, mut hi) = ([x0, y0, 0.48], [x1, y1, 0.93]);
    let (axis, at_hi) = back;
    if at_hi {
        lo[axis] = hi[axis] - 0.04;
    } else {
        hi[axis] = lo[axis] + 0.04;
    }
    add_box(
        s,
        &format!("{name}.back"),
        lo,
        hi,
        Faces::NO_BOTTOM,
        fabric,
        None,
    );
    for (k, (lx, ly)) in [(x0 + 0.02, y0 + 0.02), (x1 - 0.05, y0 + 0.02)]
        .into_iter()
        .chain([(x0 + 0.02, y1 - 0.05), (x1 - 0.05, y1 - 0.05)])
        .enumerate()
    {
        add_box(
            s,
            &format!("{name}.leg{k}"),
            [lx, ly, 0.0],
            [lx + 0.03, ly + 0.03, 0.43],
            Faces::SIDES,
            metal,
            None,
        );
    }
}

/// The bookshelf against the west wall: `x ∈ [0.01, 0.35]`, `y ∈ [1.8, 3.0]`, 2 m
/// high, a back panel, two sides, a top, a plinth, three shelves and six books on each
/// of the four boards (23 + 96 surfaces).
fn bookshelf(s: &mut Scene, p: &Palette) {
    let (x0, x1, y0, y1) = (0.01, 0.35, 1.8, 3.0);
    let t = 0.02;
    s.add_surface(Surface {
        name: "shelf.back".into(),
        shape: Shape::parallelogram(
            DVec3::new(x0, y0 + t, 0.0),
            DVec3::new(0.0, y1 - y0 - 2.0 * t, 0.0),
            DVec3::new(0.0, 0.0, 2.0 - t),
        ),
        material: p.shelf,
        sides: Sidedness::OneSided,
    });
    // Sides: outer, inner, front (+x) and top faces; the back is against the wall.
    let side = Faces {
        lo: [false, true, false],
        hi: [true, true, true],
    };
    add_box(
        s,
        "shelf.side0",
        [x0, y0, 0.0],
        [x1, y0 + t, 2.0],
        side,
        p.shelf,
        None,
    );
    add_box(
        s,
        "shelf.side1",
        [x0, y1 - t, 0.0],
        [x1, y1, 2.0],
        side,
        p.shelf,
        None,
    );
    // Boards between the sides: top, bottom and front faces (the plinth has no
    // bottom: it stands on the floor).
    let board = Faces {
        lo: [false, false, true],
        hi: [true, false, true],
    };
    let boards = [
        (0.0, 0.08),
        (0.5, 0.52),
        (1.0, 1.02),
        (1.5, 1.52),
        (1.98, 2.0),
    ];
    for (k, &(z0, z1)) in boards.iter().enumerate() {
        let faces = if k == 0 {
            board.without(2, false)
        } else {
            board
        };
        let name = match k {
            0 => "shelf.plinth".to_string(),
            4 => "shelf.top".to_string(),
            _ => format!("shelf.board{k}"),
        };
        add_box(
            s,
            &name,
            [x0, y0 + t, z0],
            [x1 - 0.01, y1 - t, z1],
            faces,
            p.shelf,
            None,
        );
    }
    // Books: four faces each (top, front, two sides), standing on the boards with
    // gaps between them; height and width vary.
    let book = Faces {
        lo: [false, true, false],
        hi: [true, true, true],
    };
    let widths = [0.04, 0.06, 0.05, 0.08, 0.045, 0.07];
    let heights = [0.26, 0.3, 0.22, 0.34, 0.28, 0.24];
    for (b, &(_, z1)) in boards.iter().take(4).enumerate() {
        let mut y = y0 + t + 0.05 + 0.07 * b as f64;
        for k in 0..6 {
            let (w, h) = (widths[(k + b) % 6], heights[(k + 2 * b) % 6]);
            let depth = 0.2 + 0.02 * ((k + b) % 3) as f64;
            add_box(
                s,
                &format!("book{b}.{k}"),
                [x0, y, z1],
                [x0 + depth, y + w, z1 + h],
                book,
                p.books[(k + 2 * b) % p.books.len()],
                None,
            );
            y += w + 0.03;
        }
    }
}

/// The luminaire over the room's centre: a 1.2 m × 0.3 m × 0.12 m housing open at the
/// bottom (two-sided sheets: painted outside, white reflector inside) hanging from two
/// rods, the emitting tube inside it, and five crosswise louvres across the opening
/// (24 surfaces).
fn luminaire(s: &mut Scene) {
    let outside = s.add_material(Material::lambertian(
        "housing",
        Rgb::new(0.6, 0.6, 0.62),
        Rgb::BLACK,
    ));
    let reflector = s.add_material(Material::lambertian(
        "reflector",
        Rgb::grey(0.85),
        Rgb::BLACK,
    ));
    let louvre = s.add_material(Material::lambertian(
        "louvre",
        Rgb::new(0.8, 0.8, 0.82),
        Rgb::BLACK,
    ));
    let tube = s.add_material(Material::lambertian(
        "tube",
        Rgb::grey(0.5),
        OFFICE_TUBE_EXITANCE,
    ));
    let metal = s.material_id("metal").unwrap_or(outside);
    let (x0, x1, y0, y1, z0, z1) = (1.9, 3.1, 1.85, 2.15, 2.33, 2.45);
    add_box(
        s,
        "luminaire.housing",
        [x0, y0, z0],
        [x1, y1, z1],
        Faces::NO_BOTTOM,
        outside,
        Some(reflector),
    );
    add_box(
        s,
        "luminaire.tube",
        [1.95, 1.985, 2.385],
        [3.05, 2.015, 2.415],
        Faces::ALL,
        tube,
        None,
    );
    for k in 0..5 {
        let x = 2.1 + 0.2 * k as f64;
        s.add_surface(Surface {
            name: format!("luminaire.louvre{k}"),
            shape: Shape::parallelogram(
                DVec3::new(x, y0, z0),
                DVec3::new(0.0, y1 - y0, 0.0),
                DVec3::new(0.0, 0.0, 0.04),
            ),
            material: louvre,
            sides: Sidedness::TwoSided { back: louvre },
        });
    }
    for (k, x) in [2.0, 3.0].into_iter().enumerate() {
        add_box(
            s,
            &format!("luminaire.rod{k}"),
            [x - 0.005, 1.995, z1],
            [x + 0.005, 2.005, OFFICE_ROOM[2]],
            Faces::SIDES,
            metal,
            None,
        );
    }
}

/// The room: floor, ceiling, four walls (the west one notched for the door, the east
/// one with a window hole), the door and the window pane (8 surfaces).
fn room(s: &mut Scene) {
    let [rx, ry, rz] = OFFICE_ROOM;
    let wall = s.add_material(Material::lambertian(
        "wall",
        Rgb::new(0.72, 0.7, 0.66),
        Rgb::BLACK,
    ));
    let ceiling = s.add_material(Material::lambertian(
        "ceiling",
        Rgb::new(0.8, 0.8, 0.78),
        Rgb::BLACK,
    ));
    let carpet = s.add_material(Material::lambertian(
        "carpet",
        Rgb::new(0.3, 0.25, 0.2),
        Rgb::BLACK,
    ));
    let door = s.add_material(Material::lambertian(
        "door",
        Rgb::new(0.45, 0.3, 0.18),
        Rgb::BLACK,
    ));
    let glass = s.add_material(Material::lambertian(
        "glass",
        Rgb::new(0.04, 0.05, 0.06),
        Rgb::BLACK,
    ));
    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    one_sided(
        s,
        "floor",
        Shape::parallelogram(DVec3::ZERO, x * rx, y * ry),
        carpet,
    );
    one_sided(
        s,
        "ceiling",
        Shape::parallelogram(z * rz, y * ry, x * rx),
        ceiling,
    );
    one_sided(
        s,
        "wall_south",
        Shape::parallelogram(DVec3::ZERO, z * rz, x * rx),
        wall,
    );
    one_sided(
        s,
        "wall_north",
        Shape::parallelogram(y * ry, x * rx, z * rz),
        wall,
    );
    // West wall (x = 0, facing +x; frame coordinates (y, z)) with the door notch
    // y ∈ [0.4, 1.3], z ∈ [0, 2.05].
    let (d0, d1, dh) = (0.4, 1.3, 2.05);
    let west = PlaneFrame {
        origin: DVec3::ZERO,
        u: y,
        v: z,
    };
    let notched = Loop::polygon(&[
        DVec2::new(0.0, 0.0),
        DVec2::new(d0, 0.0),
        DVec2::new(d0, dh),
        DVec2::new(d1, dh),
        DVec2::new(d1, 0.0),
        DVec2::new(ry, 0.0),
        DVec2::new(ry, rz),
        DVec2::new(0.0, rz),
    ]);
    one_sided(
        s,
        "wall_west",
        Shape::Polygon(PolygonShape {
            frame: west,
            outer: notched,
            holes: Vec::new(),
        }),
        wall,
    );
    one_sided(
        s,
        "door",
        Shape::parallelogram(y * d0, y * (d1 - d0), z * dh),
        door,
    );
    // East wall (x = 5, facing −x; frame coordinates (z, y)) with the window
    // z ∈ [0.9, 2.2], y ∈ [1.0, 3.0].
    let east = PlaneFrame {
        origin: x * rx,
        u: z,
        v: y,
    };
    one_sided(
        s,
        "wall_east",
        rect_with_hole(
            east,
            [DVec2::ZERO, DVec2::new(rz, ry)],
            [DVec2::new(0.9, 1.0), DVec2::new(2.2, 3.0)],
        ),
        wall,
    );
    one_sided(
        s,
        "window",
        Shape::parallelogram(x * rx + y * 1.0 + z * 0.9, z * 1.3, y * 2.0),
        glass,
    );
}

/// The furnished office (see the module docs): 343 surfaces, one camera standing by
/// the south-east corner at eye height looking at the desks, the bookshelf and the
/// luminaire (eye `(4.7, 0.3, 1.65)`, target `(1.2, 3.0, 0.9)`, up `+z`, vertical field
/// of view 70°, aspect 1).
pub fn office() -> Scene {
    let mut s = Scene::new("office");
    room(&mut s);
    let metal = s.add_material(Material::lambertian(
        "metal",
        Rgb::new(0.55, 0.55, 0.57),
        Rgb::BLACK,
    ));
    let p = Palette {
        desk: s.add_material(Material::lambertian(
            "desk",
            Rgb::new(0.6, 0.45, 0.3),
            Rgb::BLACK,
        )),
        metal,
        casing: s.add_material(Material::lambertian("casing", Rgb::grey(0.1), Rgb::BLACK)),
        screen: s.add_material(Material::lambertian(
            "screen",
            Rgb::new(0.02, 0.02, 0.03),
            Rgb::BLACK,
        )),
        shelf: s.add_material(Material::lambertian(
            "shelf",
            Rgb::new(0.65, 0.55, 0.4),
            Rgb::BLACK,
        )),
        books: [
            (0.55, 0.1, 0.08),
            (0.1, 0.3, 0.55),
            (0.15, 0.4, 0.15),
            (0.7, 0.65, 0.5),
            (0.35, 0.2, 0.45),
            (0.75, 0.55, 0.1),
        ]
        .iter()
        .enumerate()
        .map(|(k, &(r, g, b))| {
            s.add_material(Material::lambertian(
                format!("book{k}"),
                Rgb::new(r, g, b),
                Rgb::BLACK,
            ))
        })
        .collect(),
    };
    luminaire(&mut s);
    desk(&mut s, "desk_a", 0.8, &p);
    desk(&mut s, "desk_b", 2.9, &p);
    let blue = s.add_material(Material::lambertian(
        "fabric_blue",
        Rgb::new(0.12, 0.2, 0.45),
        Rgb::BLACK,
    ));
    let red = s.add_material(Material::lambertian(
        "fabric_red",
        Rgb::new(0.5, 0.12, 0.1),
        Rgb::BLACK,
    ));
    chair(&mut s, "chair_a", [1.6, 2.6], (1, false), blue, metal);
    chair(&mut s, "chair_b", [3.7, 2.6], (1, false), blue, metal);
    chair(&mut s, "chair_c", [1.3, 1.0], (0, false), red, metal);
    chair(&mut s, "chair_d", [3.4, 0.9], (1, false), red, metal);
    bookshelf(&mut s, &p);
    // Filing cabinet in the north-west corner, front facing +x, with three drawer
    // fronts protruding 2 cm.
    let cabinet = s.add_material(Material::lambertian(
        "cabinet",
        Rgb::new(0.45, 0.47, 0.5),
        Rgb::BLACK,
    ));
    add_box(
        &mut s,
        "cabinet",
        [0.05, 3.3, 0.0],
        [0.55, 3.9, 1.0],
        Faces::NO_BOTTOM,
        cabinet,
        None,
    );
    for k in 0..3 {
        let z = 0.05 + 0.32 * k as f64;
        add_box(
            &mut s,
            &format!("cabinet.drawer{k}"),
            [0.55, 3.33, z],
            [0.57, 3.87, z + 0.28],
            Faces::ALL.without(0, false),
            cabinet,
            None,
        );
    }
    if let Some(cam) = Camera::look_at(
        "camera",
        DVec3::new(4.7, 0.3, 1.65),
        DVec3::new(1.2, 3.0, 0.9),
        DVec3::Z,
        70f64.to_radians(),
        Some(1.0),
    ) {
        s.cameras.push(cam);
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn office_is_valid_and_has_its_surface_count() {
        let s = office();
        s.validate("builtin:office").unwrap();
        assert_eq!(s.surfaces.len(), OFFICE_SURFACES);
        assert!(s.surfaces.len() >= 200);
        let emitters: Vec<&str> = s
            .surfaces
            .iter()
            .filter(|x| s.materials[x.material].is_emitter())
            .map(|x| x.name.as_str())
            .collect();
        assert_eq!(emitters.len(), 6, "{emitters:?}");
        assert!(emitters.iter().all(|n| n.starts_with("luminaire.tube")));
    }

    /// Every face of a box points out of it, and everything lies inside the room.
    #[test]
    fn faces_point_outwards_and_stay_in_the_room() {
        let (lo, hi) = (DVec3::new(1.0, 2.0, 3.0), DVec3::new(1.5, 2.25, 3.75));
        let c = 0.5 * (lo + hi);
        for axis in 0..3 {
            for at_hi in [false, true] {
                let Shape::Parallelogram {
                    origin,
                    edge_u,
                    edge_v,
                } = box_face(lo, hi, axis, at_hi)
                else {
                    panic!("not a parallelogram");
                };
                let n = edge_u.cross(edge_v);
                let centre = origin + 0.5 * (edge_u + edge_v);
                assert!(n.dot(centre - c) > 0.0, "axis {axis} hi {at_hi}");
                assert!((centre[axis] - if at_hi { hi[axis] } else { lo[axis] }).abs() < 1e-12);
            }
        }
        let room = DVec3::from_array(OFFICE_ROOM);
        let s = office();
        for (i, prim) in s.primitives("builtin:office").unwrap() {
            let b = prim.aabb();
            assert!(
                b.min.cmpge(DVec3::splat(-1e-12)).all() && b.max.cmple(room + 1e-12).all(),
                "{} at {b:?}",
                s.surfaces[i].name
            );
        }
    }
}
