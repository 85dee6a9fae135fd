//! Built-in participating-medium scenes of the Global Cube (GlobalCube §5, Figs. 11–14),
//! rebuilt from the paper's captions (it gives no geometry, so the layout, sizes,
//! colours, extinctions and powers below are ours):
//!
//! - `gc-lounge` (§5.1, Fig. 11, Table 1): "two sofas, a semi-transparent table, a
//!   light source, a book on the table and participating media". A 4 m cube room, open
//!   at the front (`+z`) and the top: an opaque floor, back wall (`z = 0`) and left wall
//!   (`x = 0`), each 1/32 of the room thick; a red sofa along the back wall and a blue
//!   one along the left wall (seat, back rest and arm rests, opaque); a glass table
//!   (a top of extinction 6/m — optical depth 0.75 across its 12.5 cm — on four opaque
//!   legs) with an opaque book on it; a standing lamp in the back right corner (an
//!   opaque stand and a glowing shade: a source of 60 W per channel, warm white, in a
//!   medium of extinction 4/m); haze of extinction 0.05/m (optical depth 0.2 across the
//!   room) and albedo 0.8 filling the rest.
//! - `gc-entrance` (§5.1, Fig. 12): "the entrance of a house. Three lights illuminate
//!   the scene: one square light on the ceiling, and two smaller lights on the side of
//!   the door hidden by two red panels". The same 4 m room with a ceiling (open at the
//!   front); a brown door in the back wall; a square ceiling light (40 W per channel,
//!   0.8 m square, hanging 1/16 of the room below the ceiling); either side of the door
//!   a small light (10 W per channel each) behind a red opaque panel that stands
//!   0.2 m in front of the wall; haze as in the lounge.
//!
//! Each is built at any resolution `n = 2^k` (2 ≤ n ≤ 256; default 64, the paper's
//! `64³`): `gc-lounge-16`, `gc-entrance-32`, ... A part is an axis-aligned box in the
//! room's unit cube; it covers the voxels whose index range `[round(lo·n),
//! round(hi·n))` it spans per axis, at least the voxel of its centre (thin parts stay
//! one voxel thick at every resolution). Later parts replace earlier ones. Opacities
//! come from extinctions, `σ = 1 − e^{−κh}` (so the optical depth of a part does not
//! depend on `n`) or are 1 (opaque, GlobalCube §2.1's surfaces as thin volumes); a
//! source's power is spread evenly over its voxels (W/m³ = power / covered volume),
//! so the total power is the same at every `n`. The camera looks into the open front.
//! Axes: `y` up; metres; sources in W (per channel).

use glam::DVec3;

use crate::camera::Camera;
use crate::material::Rgb;
use crate::medium::Medium;
use crate::scene::Scene;

/// Names of the scenes of this module (at their default resolution).
pub const NAMES: &[&str] = &["gc-lounge", "gc-entrance"];

/// Default resolution (GlobalCube §5: `64³`).
pub const DEFAULT_RESOLUTION: usize = 64;

/// Largest resolution accepted in a name (`gc-lounge-256`).
pub const MAX_RESOLUTION: usize = 256;

/// Room edge (m).
pub const ROOM: f64 = 4.0;

/// Extinction of the haze (1/m).
pub const HAZE_EXTINCTION: f64 = 0.05;

/// Albedo of the haze.
pub const HAZE_ALBEDO: f64 = 0.8;

/// A scene of this module by name: `gc-lounge`, `gc-entrance` (at
/// [`DEFAULT_RESOLUTION`]) or `NAME-<n>` with `n` a power of two in
/// `2..=`[`MAX_RESOLUTION`].
pub fn by_name(name: &str) -> Option<Scene> {
    let (base, n) = match name.rsplit_once('-') {
        Some((b, r)) if r.bytes().all(|c| c.is_ascii_digit()) => (b, r.parse().ok()?),
        _ => (name, DEFAULT_RESOLUTION),
    };
    if !(2..=MAX_RESOLUTION).contains(&n) || !n.is_power_of_two() {
        return None;
    }
    let mut s = match base {
        "gc-lounge" => lounge(n),
        "gc-entrance" => entrance(n),
        _ => return None,
    };
    s.name = name.to_string();
    Some(s)
}

/// What a part is made of.
#[derive(Clone, Copy)]
enum Stuff {
    /// Opaque (σ = 1), reflectance `albedo`.
    Opaque(Rgb),
    /// Medium of extinction (1/m) and albedo.
    Medium(f64, Rgb),
}

/// An axis-aligned box of the unit room with its material and emitted power (W).
struct Part {
    lo: [f64; 3],
    hi: [f64; 3],
    stuff: Stuff,
    power: Rgb,
}

fn part(lo: [f64; 3], hi: [f64; 3], stuff: Stuff) -> Part {
    Part {
        lo,
        hi,
        stuff,
        power: Rgb::grey(0.0),
    }
}

/// Voxel index range of `[lo, hi)` at resolution `n` (at least the centre voxel).
fn span(lo: f64, hi: f64, n: usize) -> std::ops::Range<usize> {
    let nf = n as f64;
    let a = ((lo * nf).round().max(0.0) as usize).min(n);
    let b = ((hi * nf).round().max(0.0) as usize).min(n);
    if b > a {
        a..b
    } else {
        let c = ((0.5 * (lo + hi) * nf).floor().max(0.0) as usize).min(n - 1);
        c..c + 1
    }
}

/// Rasterises the parts over haze into a medium of `n³` voxels over the room.
fn rasterise(name: &str, n: usize, parts: &[Part]) -> Medium {
    let h = ROOM / n as f64;
    let haze = 1.0 - (-HAZE_EXTINCTION * h).exp();
    let mut m = Medium::uniform(
        name,
        DVec3::ZERO,
        DVec3::splat(ROOM),
        [n, n, n],
        Rgb::grey(0.0),
        haze,
        Rgb::grey(HAZE_ALBEDO),
    );
    for p in parts {
        let r: [std::ops::Range<usize>; 3] = std::array::from_fn(|a| span(p.lo[a], p.hi[a], n));
        let count = r.iter().map(ExactSizeIterator::len).product::<usize>();
        let density = p.power.scale(1.0 / (count as f64 * h * h * h));
        for z in r[2].clone() {
            for y in r[1].clone() {
                for x in r[0].clone() {
                    let i = m.index(x, y, z);
                    match p.stuff {
                        Stuff::Opaque(a) => {
                            m.opacity[i] = 1.0;
                            m.albedo[i] = a;
                        }
                        Stuff::Medium(kappa, a) => {
                            m.opacity[i] = 1.0 - (-kappa * h).exp();
                            m.albedo[i] = a;
                        }
                    }
                    m.source[i] = density;
                }
            }
        }
    }
    m
}

/// Wall thickness as a fraction of the room.
const WALL: f64 = 1.0 / 32.0;

fn room_camera() -> Camera {
    Camera::look_at(
        "front",
        DVec3::new(0.5, 0.55, 2.1) * ROOM,
        DVec3::new(0.5, 0.3, 0.4) * ROOM,
        DVec3::Y,
        45f64.to_radians(),
        None,
    )
    .expect("valid camera")
}

fn scene(name: &str, n: usize, parts: &[Part]) -> Scene {
    let mut s = Scene::new(name);
    s.media.push(rasterise(name, n, parts));
    s.cameras.push(room_camera());
    s
}

/// A sofa: seat, back rest (on the side `back` of the seat: 0 = `−z`, 1 = `−x`) and
/// two arm rests, in the unit room.
fn sofa(lo: [f64; 2], hi: [f64; 2], back: usize, colour: Rgb) -> Vec<Part> {
    let o = Stuff::Opaque(colour);
    let (seat, top, arm) = (0.2, 0.4, 0.28);
    let (x0, z0, x1, z1) = (lo[0], lo[1], hi[0], hi[1]);
    let d = 0.07;
    if back == 0 {
        vec![
            part([x0, WALL, z0], [x1, seat, z1], o),
            part([x0, seat, z0], [x1, top, z0 + d], o),
            part([x0, seat, z0], [x0 + d, arm, z1], o),
            part([x1 - d, seat, z0], [x1, arm, z1], o),
        ]
    } else {
        vec![
            part([x0, WALL, z0], [x1, seat, z1], o),
            part([x0, seat, z0], [x0 + d, top, z1], o),
            part([x0, seat, z0], [x1, arm, z0 + d], o),
            part([x0, seat, z1 - d], [x1, arm, z1], o),
        ]
    }
}

/// `gc-lounge` at resolution `n` (see the module documentation).
#[must_use]
pub fn lounge(n: usize) -> Scene {
    let wall = Stuff::Opaque(Rgb::new(0.7, 0.68, 0.62));
    let mut parts = vec![
        part(
            [0.0, 0.0, 0.0],
            [1.0, WALL, 1.0],
            Stuff::Opaque(Rgb::new(0.5, 0.4, 0.3)),
        ),
        part([0.0, 0.0, 0.0], [1.0, 1.0, WALL], wall),
        part([0.0, 0.0, 0.0], [WALL, 1.0, 1.0], wall),
    ];
    parts.extend(sofa([0.2, 0.06], [0.7, 0.3], 0, Rgb::new(0.7, 0.12, 0.1)));
    parts.extend(sofa([0.06, 0.4], [0.3, 0.9], 1, Rgb::new(0.12, 0.2, 0.6)));
    // Glass table: top of extinction 6/m on four opaque legs.
    let leg = Stuff::Opaque(Rgb::grey(0.3));
    let (t0, t1) = ([0.42, 0.47], [0.78, 0.78]);
    for (x, z) in [
        (t0[0], t0[1]),
        (t1[0] - 0.03, t0[1]),
        (t0[0], t1[1] - 0.03),
        (t1[0] - 0.03, t1[1] - 0.03),
    ] {
        parts.push(part([x, WALL, z], [x + 0.03, 0.22, z + 0.03], leg));
    }
    parts.push(part(
        [t0[0], 0.22, t0[1]],
        [t1[0], 0.25125, t1[1]],
        Stuff::Medium(6.0, Rgb::new(0.55, 0.8, 0.7)),
    ));
    // A book on the table.
    parts.push(part(
        [0.52, 0.25125, 0.56],
        [0.62, 0.28, 0.66],
        Stuff::Opaque(Rgb::new(0.15, 0.3, 0.75)),
    ));
    // Standing lamp in the back right corner: stand and glowing shade.
    parts.push(part(
        [0.84, WALL, 0.14],
        [0.87, 0.55, 0.17],
        Stuff::Opaque(Rgb::grey(0.2)),
    ));
    parts.push(Part {
        power: Rgb::new(60.0, 54.0, 42.0),
        ..part(
            [0.78, 0.55, 0.08],
            [0.93, 0.68, 0.23],
            Stuff::Medium(4.0, Rgb::new(0.9, 0.85, 0.7)),
        )
    });
    scene("gc-lounge", n, &parts)
}

/// `gc-entrance` at resolution `n` (see the module documentation).
#[must_use]
pub fn entrance(n: usize) -> Scene {
    let wall = Stuff::Opaque(Rgb::new(0.75, 0.72, 0.66));
    let red = Stuff::Opaque(Rgb::new(0.75, 0.1, 0.08));
    let mut parts = vec![
        part(
            [0.0, 0.0, 0.0],
            [1.0, WALL, 1.0],
            Stuff::Opaque(Rgb::new(0.45, 0.45, 0.45)),
        ),
        part([0.0, 1.0 - WALL, 0.0], [1.0, 1.0, 1.0], wall),
        part([0.0, 0.0, 0.0], [1.0, 1.0, WALL], wall),
        part([0.0, 0.0, 0.0], [WALL, 1.0, 1.0], wall),
        part([1.0 - WALL, 0.0, 0.0], [1.0, 1.0, 1.0], wall),
        // The door, flush with the back wall.
        part(
            [0.4, WALL, 0.0],
            [0.6, 0.55, WALL],
            Stuff::Opaque(Rgb::new(0.4, 0.24, 0.12)),
        ),
    ];
    // Ceiling light.
    parts.push(Part {
        power: Rgb::new(40.0, 40.0, 36.0),
        ..part(
            [0.4, 1.0 - WALL - 1.0 / 16.0, 0.4],
            [0.6, 1.0 - 1.0 / 16.0, 0.6],
            Stuff::Opaque(Rgb::grey(0.8)),
        )
    });
    // Two small lights by the door, each behind a red panel 0.2 m (1/20) in front of
    // the wall.
    for x in [0.28, 0.66] {
        parts.push(Part {
            power: Rgb::new(10.0, 9.0, 7.0),
            ..part(
                [x, 0.3, WALL],
                [x + 0.06, 0.36, WALL + 1.0 / 32.0],
                Stuff::Opaque(Rgb::grey(0.8)),
            )
        });
        parts.push(part(
            [x - 0.02, 0.22, WALL + 0.05],
            [x + 0.08, 0.44, WALL + 0.05 + 1.0 / 32.0],
            red,
        ));
    }
    scene("gc-entrance", n, &parts)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_resolutions_and_power() {
        for base in NAMES {
            let p16 = by_name(&format!("{base}-16")).unwrap();
            let p64 = by_name(base).unwrap();
            assert_eq!(p16.media[0].resolution, [16, 16, 16]);
            assert_eq!(p64.media[0].resolution, [64, 64, 64]);
            p16.media[0].validate("builtin").unwrap();
            // The total source power does not depend on the resolution.
            let power = |m: &Medium| {
                let v = m.voxel_size();
                m.source.iter().map(|s| s.0[0]).sum::<f64>() * v.x * v.y * v.z
            };
            let (a, b) = (power(&p16.media[0]), power(&p64.media[0]));
            assert!(a > 0.0 && (a - b).abs() < 1e-9 * b, "{a} vs {b}");
        }
        assert!(by_name("gc-lounge-12").is_none());
        assert!(by_name("gc-lounge-512").is_none());
        assert!(by_name("gc-lobby").is_none());
    }

    #[test]
    fn thin_parts_stay_one_voxel_thick() {
        assert_eq!(span(0.0, 1.0 / 32.0, 4), 0..1);
        assert_eq!(span(0.5, 0.51, 8), 4..5);
        assert_eq!(span(0.0, 1.0, 8), 0..8);
        assert_eq!(span(0.99, 1.0, 2), 1..2);
    }
}
