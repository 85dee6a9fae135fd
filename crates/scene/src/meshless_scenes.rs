//! Built-in scenes of the meshless direct-to-indirect method (Meshless §4.2):
//!
//! - `atrium` (and `atrium-s`, `atrium-xl` at other tessellation densities): a
//!   courtyard standing in for the paper's Sponza Atrium (not redistributable here,
//!   ours): 24 × 12 m, 12 m high, open to the sky; two-storey round-arched arcades on
//!   both long sides (lathe columns with plinths and capitals, arched spandrel walls
//!   with soffits), galleries behind them (floor slab, ceiling, roof, back wall),
//!   arched doors in both end walls, six two-sided waved drapes hanging in front of the
//!   upper arcades and four urns in the courtyard. Everything is a triangle mesh; the
//!   default density has 60k–72k triangles (tested), `atrium-s` ≈ 16k and
//!   `atrium-xl` ≈ 1M (same shapes, finer tessellation). The camera stands at the
//!   `x = 0` end; a spot light hangs at the other end aiming down the courtyard.
//! - `leak-rooms`: two open-topped 4 × 3 × 4 m rooms side by side separated by a wall
//!   `1e-3 ×` the scene diagonal thick, a spot in the first (Meshless §5.2: coarse basis
//!   functions leak through thin walls); the camera looks down into both rooms. No
//!   light reaches the second room, so its exact indirect illumination is zero.
//! - `closed-sphere`: the inside of a sphere of radius 2 m (ρ = 0.5) lit by an
//!   off-centre spot: every point receives the same one-bounce irradiance
//!   `ρΦ/(4πR²)`.
//!
//! Axes: `y` up; lengths in metres; spot intensities in W/sr.

use glam::{DVec2, DVec3};

use crate::camera::Camera;
use crate::error::BUILTIN_FILE;
use crate::light::Light;
use crate::material::{Material, Rgb};
use crate::scene::{MaterialId, Scene, Sidedness, Surface};
use crate::shape::{Shape, TriangleMesh};

/// Names of the scenes of this module.
pub const NAMES: &[&str] = &[
    "atrium",
    "atrium-s",
    "atrium-xl",
    "leak-rooms",
    "closed-sphere",
];

/// Tessellation density of `atrium` (triangle count grows as its square).
pub const ATRIUM_DETAIL: f64 = 1.0;
/// Density of `atrium-s`.
pub const ATRIUM_S_DETAIL: f64 = 0.41;
/// Density of `atrium-xl`.
pub const ATRIUM_XL_DETAIL: f64 = 4.15;

/// A scene of this module by name (see [`NAMES`]).
pub fn by_name(name: &str) -> Option<Scene> {
    match name {
        "atrium" => Some(atrium(ATRIUM_DETAIL)),
        "atrium-s" => Some(named(atrium(ATRIUM_S_DETAIL), name)),
        "atrium-xl" => Some(named(atrium(ATRIUM_XL_DETAIL), name)),
        "leak-rooms" => Some(leak_rooms()),
        "closed-sphere" => Some(closed_sphere()),
        _ => None,
    }
}

fn named(mut s: Scene, name: &str) -> Scene {
    s.name = name.into();
    s
}

/// Indexed triangles under construction.
#[derive(Default)]
struct Mesh {
    pos: Vec<DVec3>,
    tris: Vec<[u32; 3]>,
}

impl Mesh {
    fn vert(&mut self, p: DVec3) -> u32 {
        self.pos.push(p);
        (self.pos.len() - 1) as u32
    }

    /// A triangle wound so that its normal points along `want`.
    fn tri(&mut self, a: DVec3, b: DVec3, c: DVec3, want: DVec3) {
        let n = (b - a).cross(c - a);
        if n.length_squared() <= 0.0 {
            return;
        }
        let (ia, ib, ic) = (self.vert(a), self.vert(b), self.vert(c));
        if n.dot(want) >= 0.0 {
            self.tris.push([ia, ib, ic]);
        } else {
            self.tris.push([ia, ic, ib]);
        }
    }

    fn quad(&mut self, a: DVec3, b: DVec3, c: DVec3, d: DVec3, want: DVec3) {
        self.tri(a, b, c, want);
        self.tri(a, c, d, want);
    }

    /// A `nu × nv` grid of `f(u, v)`, `(u, v) ∈ [0, 1]²`, front along `∂u f × ∂v f`
    /// (shared vertices).
    fn grid(&mut self, nu: usize, nv: usize, f: impl Fn(f64, f64) -> DVec3) {
        let base = self.pos.len() as u32;
        for i in 0..=nu {
            for j in 0..=nv {
                self.pos.push(f(i as f64 / nu as f64, j as f64 / nv as f64));
            }
        }
        let id = |i: usize, j: usize| base + (i * (nv + 1) + j) as u32;
        for i in 0..nu {
            for j in 0..nv {
                self.tris.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
                self.tris.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
            }
        }
    }

    /// A rectangle `o + u·eu + v·ev` gridded `nu × nv`, front along `eu × ev`.
    fn rect(&mut self, o: DVec3, eu: DVec3, ev: DVec3, nu: usize, nv: usize) {
        self.grid(nu.max(1), nv.max(1), |u, v| o + eu * u + ev * v);
    }

    /// A surface of revolution about the vertical line through `c`: `profile` is
    /// `(radius, height)` bottom to top, `segments` around; outward normals.
    fn lathe(&mut self, c: DVec3, profile: &[(f64, f64)], segments: usize) {
        let ring = |r: f64, y: f64, k: usize| {
            let phi = std::f64::consts::TAU * k as f64 / segments as f64;
            c + DVec3::new(r * phi.cos(), y, r * phi.sin())
        };
        for w in profile.windows(2) {
            let ((r0, y0), (r1, y1)) = (w[0], w[1]);
            for k in 0..segments {
                let (a, b) = (ring(r0, y0, k), ring(r1, y1, k));
                let (cc, d) = (ring(r1, y1, k + 1), ring(r0, y0, k + 1));
                // Outward ∂t × ∂φ from the diagonals (valid on degenerate rings too).
                let want = (b - d).cross(cc - a);
                if r0 > 0.0 && r1 > 0.0 {
                    self.quad(a, b, cc, d, want);
                } else if r1 > 0.0 {
                    self.tri(a, b, cc, want);
                } else if r0 > 0.0 {
                    self.tri(a, b, d, want);
                }
            }
        }
    }

    /// An axis-aligned box `[lo, hi]` with outward faces (`n` cells per metre).
    fn cuboid(&mut self, lo: DVec3, hi: DVec3) {
        let d = hi - lo;
        let (x, y, z) = (DVec3::X * d.x, DVec3::Y * d.y, DVec3::Z * d.z);
        self.rect(lo, z, x, 1, 1); // bottom, −y
        self.rect(lo + y, x, z, 1, 1); // top, +y
        self.rect(lo, x, y, 1, 1); // z = lo, −z
        self.rect(lo + z, y, x, 1, 1); // z = hi, +z
        self.rect(lo, y, z, 1, 1); // x = lo, −x
        self.rect(lo + x, z, y, 1, 1); // x = hi, +x
    }

    /// The region of the wall rectangle `[x0, x1] × [y0, y1]` (wall coordinates mapped
    /// by `map`) outside the half-disc of radius `rad` centred at `(xc, y0)`, as a strip
    /// from the arc to the rectangle's boundary; front along `want`.
    fn spandrel(
        &mut self,
        map: &impl Fn(DVec2) -> DVec3,
        x0: f64,
        x1: f64,
        y0: f64,
        y1: f64,
        xc: f64,
        rad: f64,
        segments: usize,
        want: DVec3,
    ) {
        let c = DVec2::new(xc, y0);
        let mut angles: Vec<f64> = (0..=segments)
            .map(|k| std::f64::consts::PI * k as f64 / segments as f64)
            .collect();
        angles.push((y1 - y0).atan2(x1 - xc));
        angles.push((y1 - y0).atan2(x0 - xc));
        angles.sort_by(f64::total_cmp);
        angles.dedup_by(|a, b| (*a - *b).abs() < 1e-12);
        let outer = |t: f64| {
            let d = DVec2::new(t.cos(), t.sin());
            let mut s = f64::INFINITY;
            if d.x > 1e-12 {
                s = s.min((x1 - xc) / d.x);
            }
            if d.x < -1e-12 {
                s = s.min((x0 - xc) / d.x);
            }
            if d.y > 1e-12 {
                s = s.min((y1 - y0) / d.y);
            }
            c + d * s
        };
        let arc = |t: f64| c + DVec2::new(t.cos(), t.sin()) * rad;
        for w in angles.windows(2) {
            let (t0, t1) = (w[0], w[1]);
            self.quad(
                map(arc(t0)),
                map(outer(t0)),
                map(outer(t1)),
                map(arc(t1)),
                want,
            );
        }
    }

    fn into_shape(self) -> Shape {
        match TriangleMesh::build(self.pos, Vec::new(), &self.tris, BUILTIN_FILE, "mesh") {
            Ok(b) => Shape::Mesh(b.mesh),
            Err(_) => Shape::Mesh(TriangleMesh::default()),
        }
    }
}

fn add(scene: &mut Scene, name: &str, mesh: Mesh, material: MaterialId, sides: Sidedness) {
    if mesh.tris.is_empty() {
        return;
    }
    scene.add_surface(Surface {
        name: name.into(),
        shape: mesh.into_shape(),
        material,
        sides,
    });
}

fn scaled(n: f64, detail: f64) -> usize {
    ((n * detail).round() as usize).max(1)
}

// ---------------------------------------------------------------------------------
// Atrium
// ---------------------------------------------------------------------------------

/// Courtyard length (x), width (z), height (y).
const LEN: f64 = 24.0;
const WID: f64 = 12.0;
const HGT: f64 = 12.0;
/// Gallery depth (back wall at z = 0 to the arcade's courtyard face).
const DEPTH: f64 = 2.6;
/// Arcade wall thickness.
const THICK: f64 = 0.6;
/// Bay width and half-width of the solid over a column.
const BAY: f64 = 3.0;
const PIER: f64 = 0.35;
/// Storey floor heights and arch spring heights.
const STOREY: [f64; 2] = [0.0, 6.0];
const SPRING: [f64; 2] = [3.5, 8.8];
const TOP: [f64; 2] = [6.0, 12.0];

/// The atrium at tessellation density `detail` (see the module docs; `1.0`: 60k–72k
/// triangles).
pub fn atrium(detail: f64) -> Scene {
    let d = detail.max(0.05);
    let mut s = Scene::new("atrium");
    let m = AtriumMaterials::add(&mut s);
    let one = Sidedness::OneSided;
    // Floor (the whole footprint, galleries included).
    let mut floor = Mesh::default();
    floor.rect(
        DVec3::ZERO,
        DVec3::Z * WID,
        DVec3::X * LEN,
        scaled(WID * 4.0, d),
        scaled(LEN * 4.0, d),
    );
    add(&mut s, "floor", floor, m.floor, one);
    for side in [Side::South, Side::North] {
        let tag = side.tag();
        add(
            &mut s,
            &format!("{tag}-gallery"),
            side.gallery(d),
            m.stone,
            one,
        );
        add(
            &mut s,
            &format!("{tag}-arcade"),
            side.arcade(d),
            m.stone,
            one,
        );
        add(
            &mut s,
            &format!("{tag}-columns"),
            side.columns(d),
            m.stone,
            one,
        );
        side.drapes(&mut s, d, m.drape);
    }
    atrium_end_walls(&mut s, d, m.stone);
    atrium_urns(&mut s, d, m.urn);
    if let Some(cam) = Camera::look_at(
        "end",
        DVec3::new(1.2, 1.7, WID / 2.0),
        DVec3::new(LEN, 3.5, WID / 2.0),
        DVec3::Y,
        60f64.to_radians(),
        None,
    ) {
        s.cameras.push(cam);
    }
    s.lights.push(Light::spot(
        "spot",
        DVec3::new(20.0, 10.5, 6.0),
        DVec3::new(-12.0, -10.5, -1.5),
        30f64.to_radians(),
        40f64.to_radians(),
        Rgb::grey(400.0),
    ));
    s
}

/// The atrium's materials.
struct AtriumMaterials {
    stone: MaterialId,
    floor: MaterialId,
    urn: MaterialId,
    drape: [MaterialId; 3],
}

impl AtriumMaterials {
    fn add(s: &mut Scene) -> AtriumMaterials {
        let mut lambert = |name: &str, r: f64, g: f64, b: f64| {
            s.add_material(Material::lambertian(name, Rgb::new(r, g, b), Rgb::BLACK))
        };
        let stone = lambert("stone", 0.62, 0.56, 0.46);
        let floor = lambert("floor", 0.5, 0.48, 0.42);
        let urn = lambert("terracotta", 0.55, 0.32, 0.2);
        let drape = [
            lambert("drape-red", 0.6, 0.08, 0.06),
            lambert("drape-green", 0.1, 0.45, 0.12),
            lambert("drape-blue", 0.08, 0.15, 0.55),
        ];
        AtriumMaterials {
            stone,
            floor,
            urn,
            drape,
        }
    }
}

/// One long side of the atrium: the south side is built at `z ≥ 0` near `z = 0`, the
/// north side is its mirror image `z → WID − z` (normals mirrored with it).
#[derive(Clone, Copy, PartialEq)]
enum Side {
    South,
    North,
}

impl Side {
    fn tag(self) -> &'static str {
        match self {
            Side::South => "south",
            Side::North => "north",
        }
    }

    /// Index of the side (0 south, 1 north), which picks the drapes' colours.
    fn index(self) -> usize {
        usize::from(self == Side::North)
    }

    /// A point of the south side mapped to this side.
    fn p(self, p: DVec3) -> DVec3 {
        match self {
            Side::South => p,
            Side::North => DVec3::new(p.x, p.y, WID - p.z),
        }
    }

    /// A direction of the south side mapped to this side.
    fn v(self, v: DVec3) -> DVec3 {
        match self {
            Side::South => v,
            Side::North => DVec3::new(v.x, v.y, -v.z),
        }
    }

    /// Adds `b`'s triangles mapped to this side, with their winding's normal (mirrored
    /// on the north side, so that the normals stay outward).
    fn add_mapped(self, out: &mut Mesh, b: &Mesh) {
        for t in &b.tris {
            let [a, bb, c] = t.map(|i| self.p(b.pos[i as usize]));
            let n = (bb - a).cross(c - a);
            out.tri(a, bb, c, if self == Side::South { n } else { -n });
        }
    }

    /// Back wall (facing the courtyard), gallery slab (upper floor, top and
    /// underside) and the ceiling under the roof.
    fn gallery(self, d: f64) -> Mesh {
        let mut gal = Mesh::default();
        let grid = 4.0 * d; // cells per metre on large planes
        let (o, eu, ev) = (self.p(DVec3::ZERO), DVec3::X * LEN, DVec3::Y * HGT);
        let want = self.v(DVec3::Z);
        let (nu, nv) = (scaled(LEN * grid / d, d), scaled(HGT * grid / d, d));
        for i in 0..nu {
            for j in 0..nv {
                let p = |a: usize, b: usize| {
                    o + eu * (a as f64 / nu as f64) + ev * (b as f64 / nv as f64)
                };
                gal.quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1), want);
            }
        }
        let inner = DEPTH - THICK;
        let (nx, nzc) = (scaled(LEN * 2.0, d), scaled(inner * 2.0, d));
        for (y, up) in [(STOREY[1], true), (STOREY[1] - 0.2, false), (HGT, false)] {
            let want = if up { DVec3::Y } else { -DVec3::Y };
            for i in 0..nx {
                for j in 0..nzc {
                    let p = |a: usize, b: usize| {
                        self.p(DVec3::new(
                            LEN * a as f64 / nx as f64,
                            y,
                            inner * b as f64 / nzc as f64,
                        ))
                    };
                    gal.quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1), want);
                }
            }
        }
        gal
    }

    /// Arcade walls: per storey, per bay, front and back spandrels and soffits, and half
    /// piers against the end walls below the spring.
    fn arcade(self, d: f64) -> Mesh {
        let arcs = scaled(24.0, d);
        let mut wall = Mesh::default();
        for st in 0..2 {
            let (ys, yt) = (SPRING[st], TOP[st]);
            let rad = BAY / 2.0 - PIER;
            for bay in 0..8 {
                let x0 = bay as f64 * BAY;
                let xc = x0 + BAY / 2.0;
                for (zf, want) in [(DEPTH, DVec3::Z), (DEPTH - THICK, -DVec3::Z)] {
                    let map = |q: DVec2| self.p(DVec3::new(q.x, q.y, zf));
                    wall.spandrel(&map, x0, x0 + BAY, ys, yt, xc, rad, arcs, self.v(want));
                }
                // Soffit: the half-cylinder under the arch, facing its axis.
                for k in 0..arcs {
                    let t0 = std::f64::consts::PI * k as f64 / arcs as f64;
                    let t1 = std::f64::consts::PI * (k + 1) as f64 / arcs as f64;
                    let p = |t: f64, z: f64| {
                        self.p(DVec3::new(xc + rad * t.cos(), ys + rad * t.sin(), z))
                    };
                    let tm = 0.5 * (t0 + t1);
                    let inward = self.v(DVec3::new(-tm.cos(), -tm.sin(), 0.0));
                    wall.quad(
                        p(t0, DEPTH),
                        p(t1, DEPTH),
                        p(t1, DEPTH - THICK),
                        p(t0, DEPTH - THICK),
                        inward,
                    );
                }
            }
            for (xa, xb) in [(0.0, PIER), (LEN - PIER, LEN)] {
                let mut b = Mesh::default();
                b.cuboid(
                    DVec3::new(xa, STOREY[st], DEPTH - THICK),
                    DVec3::new(xb, ys, DEPTH),
                );
                self.add_mapped(&mut wall, &b);
            }
        }
        wall
    }

    /// Columns: plinth, lathe shaft (base moulding, entasis, flaring capital), abacus.
    fn columns(self, d: f64) -> Mesh {
        let around = scaled(24.0, d);
        let mut cols = Mesh::default();
        let zc = DEPTH - THICK / 2.0;
        for st in 0..2 {
            let (y0, ys) = (STOREY[st], SPRING[st]);
            let h = ys - y0;
            for k in 1..8 {
                let x = k as f64 * BAY;
                let c = self.p(DVec3::new(x, y0, zc));
                let mut b = Mesh::default();
                b.cuboid(
                    DVec3::new(x - 0.4, y0, zc - 0.4),
                    DVec3::new(x + 0.4, y0 + 0.3, zc + 0.4),
                );
                b.cuboid(
                    DVec3::new(x - 0.42, ys - 0.18, zc - 0.36),
                    DVec3::new(x + 0.42, ys, zc + 0.36),
                );
                self.add_mapped(&mut cols, &b);
                let mut prof = vec![(0.34, 0.3), (0.36, 0.38), (0.3, 0.46)];
                let rings = scaled(8.0, d);
                for i in 0..=rings {
                    let t = i as f64 / rings as f64;
                    let y = 0.5 + t * (h - 1.1);
                    let r = 0.26 - 0.04 * t + 0.02 * (std::f64::consts::PI * t).sin();
                    prof.push((r, y));
                }
                prof.extend([
                    (0.24, h - 0.55),
                    (0.28, h - 0.42),
                    (0.34, h - 0.3),
                    (0.36, h - 0.18),
                ]);
                cols.lathe(c, &prof, around);
            }
        }
        cols
    }

    /// Three two-sided waved drapes in front of the upper arcade.
    fn drapes(self, s: &mut Scene, d: f64, colours: [MaterialId; 3]) {
        for (k, bay) in [1usize, 3, 6].iter().enumerate() {
            let xc = (*bay as f64 + 0.5) * BAY;
            let z0 = DEPTH + 0.35;
            let (w, top, bottom) = (1.6, 11.4, 6.9);
            let mut dr = Mesh::default();
            let (nu, nv) = (scaled(18.0, d), scaled(40.0, d));
            dr.grid(nu, nv, |u, v| {
                let x = xc - w / 2.0 + w * u;
                let y = top - (top - bottom) * v;
                let z = z0
                    + 0.12 * (u * std::f64::consts::TAU * 2.0).sin() * (0.3 + v)
                    + 0.05 * (v * std::f64::consts::TAU * 1.5).sin();
                self.p(DVec3::new(x, y, z))
            });
            let mat = colours[(k + self.index()) % 3];
            let name = format!("{}-drape-{k}", self.tag());
            add(s, &name, dr, mat, Sidedness::TwoSided { back: mat });
        }
    }
}

/// End walls with arched doors (door 2 m wide, springing at 3 m).
fn atrium_end_walls(s: &mut Scene, d: f64, stone: MaterialId) {
    let arcs = scaled(24.0, d);
    for (end, x) in [("west", 0.0), ("east", LEN)] {
        let want = if x == 0.0 { DVec3::X } else { -DVec3::X };
        let mut m = Mesh::default();
        let map = |q: DVec2| DVec3::new(x, q.y, q.x);
        let (zd0, zd1, ys, rad) = (5.0, 7.0, 3.0, 1.0);
        let ng = |len: f64| scaled(len * 2.0, d);
        for (za, zb) in [(0.0, zd0), (zd1, WID)] {
            let (nu, nv) = (ng(zb - za), ng(HGT));
            for i in 0..nu {
                for j in 0..nv {
                    let p = |a: usize, b: usize| {
                        map(DVec2::new(
                            za + (zb - za) * a as f64 / nu as f64,
                            HGT * b as f64 / nv as f64,
                        ))
                    };
                    m.quad(p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1), want);
                }
            }
        }
        m.spandrel(&map, zd0, zd1, ys, HGT, 0.5 * (zd0 + zd1), rad, arcs, want);
        add(s, &format!("{end}-wall"), m, stone, Sidedness::OneSided);
    }
}

/// Four lathe urns in the courtyard.
fn atrium_urns(s: &mut Scene, d: f64, terracotta: MaterialId) {
    let around = scaled(24.0, d);
    for (k, (x, z)) in [(4.5, 4.5), (19.5, 4.5), (4.5, 7.5), (19.5, 7.5)]
        .iter()
        .enumerate()
    {
        let mut m = Mesh::default();
        let n = scaled(16.0, d);
        let mut prof = Vec::new();
        for i in 0..=n {
            let t = i as f64 / n as f64;
            let y = 1.3 * t;
            let r =
                0.22 + 0.3 * (std::f64::consts::PI * t * 0.9).sin() * (1.0 - 0.6 * t) - 0.12 * t;
            prof.push((r.max(0.12), y));
        }
        prof.push((0.0, 1.3));
        m.lathe(DVec3::new(*x, 0.0, *z), &prof, around);
        add(s, &format!("urn-{k}"), m, terracotta, Sidedness::OneSided);
    }
}

// ---------------------------------------------------------------------------------
// Leak rooms
// ---------------------------------------------------------------------------------

/// Two open-topped rooms separated by a wall `1e-3 ×` the scene diagonal thick (see
/// the module docs). Surfaces are named `lit-*` and `dark-*`.
pub fn leak_rooms() -> Scene {
    let mut s = Scene::new("leak-rooms");
    let white = s.add_material(Material::lambertian("white", Rgb::grey(0.7), Rgb::BLACK));
    let (w, h, dz) = (4.0, 3.0, 4.0);
    // Diagonal of the whole: (2w + t, h, dz); solve t = 1e-3·diag (fixed point).
    let mut t = 0.0;
    for _ in 0..8 {
        t = 1e-3 * DVec3::new(2.0 * w + t, h, dz).length();
    }
    for (name, x0) in [("lit", 0.0), ("dark", w + t)] {
        let mut m = Mesh::default();
        let x1 = x0 + w;
        let g = 8;
        // Floor up, four walls inward.
        m.rect(DVec3::new(x0, 0.0, 0.0), DVec3::Z * dz, DVec3::X * w, g, g);
        m.rect(DVec3::new(x0, 0.0, 0.0), DVec3::X * w, DVec3::Y * h, g, g); // z = 0, +z
        m.rect(DVec3::new(x0, 0.0, dz), DVec3::Y * h, DVec3::X * w, g, g); // z = dz, −z
        m.rect(DVec3::new(x0, 0.0, 0.0), DVec3::Y * h, DVec3::Z * dz, g, g); // x = x0, +x
        m.rect(DVec3::new(x1, 0.0, 0.0), DVec3::Z * dz, DVec3::Y * h, g, g); // x = x1, −x
        add(
            &mut s,
            &format!("{name}-room"),
            m,
            white,
            Sidedness::OneSided,
        );
    }
    if let Some(cam) = Camera::look_at(
        "above",
        DVec3::new(w + t / 2.0, 9.0, dz / 2.0 - 0.01),
        DVec3::new(w + t / 2.0, 0.0, dz / 2.0),
        DVec3::Z,
        70f64.to_radians(),
        None,
    ) {
        s.cameras.push(cam);
    }
    s.lights.push(Light::spot(
        "spot",
        DVec3::new(1.2, 2.6, 2.0),
        DVec3::new(0.6, -1.0, 0.1),
        40f64.to_radians(),
        60f64.to_radians(),
        Rgb::grey(20.0),
    ));
    s
}

/// The wall thickness of [`leak_rooms`] (m).
pub fn leak_rooms_wall() -> f64 {
    let mut t = 0.0;
    for _ in 0..8 {
        t = 1e-3 * DVec3::new(8.0 + t, 3.0, 4.0).length();
    }
    t
}

// ---------------------------------------------------------------------------------
// Closed sphere
// ---------------------------------------------------------------------------------

/// Radius of [`closed_sphere`] (m).
pub const SPHERE_RADIUS: f64 = 2.0;
/// Reflectance of [`closed_sphere`].
pub const SPHERE_RHO: f64 = 0.5;

/// The inside of a closed sphere (an exact analytic patch, two-sided with a black
/// outside) lit by an off-centre spot (module docs).
pub fn closed_sphere() -> Scene {
    use crate::analytic::{AnalyticPatch, AnalyticSurface, Placement};
    let mut s = Scene::new("closed-sphere");
    let inside = s.add_material(Material::lambertian(
        "inside",
        Rgb::grey(SPHERE_RHO),
        Rgb::BLACK,
    ));
    let outside = s.add_material(Material::lambertian("outside", Rgb::BLACK, Rgb::BLACK));
    let surface = AnalyticSurface::Sphere {
        placement: Placement {
            origin: DVec3::ZERO,
            axis: DVec3::Y,
            reference: DVec3::X,
        },
        radius: SPHERE_RADIUS,
        azimuth: (0.0, std::f64::consts::TAU),
        latitude: (-std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_2),
    };
    s.add_surface(Surface {
        name: "sphere".into(),
        shape: Shape::Patch(AnalyticPatch {
            surface,
            trim: None,
        }),
        material: outside,
        sides: Sidedness::TwoSided { back: inside },
    });
    if let Some(cam) = Camera::look_at(
        "inside",
        DVec3::new(-1.2, 0.2, -0.9),
        DVec3::new(1.0, 0.0, 1.0),
        DVec3::Y,
        80f64.to_radians(),
        None,
    ) {
        s.cameras.push(cam);
    }
    s.lights.push(Light::spot(
        "spot",
        DVec3::new(0.7, -0.4, 0.5),
        DVec3::new(-0.3, 1.0, 0.4),
        25f64.to_radians(),
        50f64.to_radians(),
        Rgb::grey(10.0),
    ));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn triangles(s: &Scene) -> usize {
        s.surfaces
            .iter()
            .map(|x| match &x.shape {
                Shape::Mesh(m) => m.triangle_count(),
                _ => 0,
            })
            .sum()
    }

    #[test]
    fn atrium_triangle_counts() {
        let a = atrium(ATRIUM_DETAIL);
        a.validate(BUILTIN_FILE).unwrap();
        let n = triangles(&a);
        assert!((60_000..=72_000).contains(&n), "atrium has {n} triangles");
        let small = triangles(&atrium(ATRIUM_S_DETAIL));
        assert!((14_000..=18_000).contains(&small), "atrium-s has {small}");
        // ≈ 1M (the Great Hall stand-in): 996,636 at ATRIUM_XL_DETAIL.
        let xl = triangles(&atrium(ATRIUM_XL_DETAIL));
        assert!((950_000..=1_050_000).contains(&xl), "atrium-xl has {xl}");
        assert_eq!(a.lights.len(), 1);
        assert_eq!(a.cameras.len(), 1);
        // Six drapes, four urns, two end walls.
        assert_eq!(
            a.surfaces
                .iter()
                .filter(|s| s.name.contains("drape"))
                .count(),
            6
        );
        assert_eq!(
            a.surfaces
                .iter()
                .filter(|s| s.name.starts_with("urn"))
                .count(),
            4
        );
    }

    #[test]
    fn lathe_normals_point_outwards() {
        let mut m = Mesh::default();
        m.lathe(
            DVec3::new(1.0, 0.0, 2.0),
            &[(0.5, 0.0), (0.6, 1.0), (0.0, 1.2)],
            12,
        );
        for t in &m.tris {
            let [a, b, c] = t.map(|i| m.pos[i as usize]);
            let n = (b - a).cross(c - a);
            let mid = (a + b + c) / 3.0 - DVec3::new(1.0, 0.6, 2.0);
            assert!(n.dot(mid) > 0.0);
        }
    }

    #[test]
    fn small_scenes_validate() {
        for name in NAMES.iter().filter(|n| **n != "atrium-xl") {
            let s = by_name(name).unwrap();
            s.validate(BUILTIN_FILE).unwrap();
            assert!(!s.lights.is_empty());
        }
        let t = leak_rooms_wall();
        assert!((t - 1e-3 * DVec3::new(8.0 + t, 3.0, 4.0).length()).abs() < 1e-12);
    }
}
