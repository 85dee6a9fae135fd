//! The analytic transfer catalogue: two-surface configurations of Howell's catalogue of
//! radiation configuration factors (C-11, C-14, C-41, B-3, B-13, the sphere interior),
//! their extremes (separation/size from 0.01 to 100, 0.01-wide strips and 0.01-long
//! common edges, form factors down to 1e-5, dihedral angles from 10° to 170°, scale
//! 1e-4 to 1e4) and the configurations a solver gets wrong first (lights partly or
//! wholly inside one receiver element, coplanar touching receivers, T-junctions).
//!
//! Every case is a scene written in the native format (parsed by the loader, as a
//! user's file would be) with a black emitter of exitance `E` and one receiver of
//! reflectance `ρ`; the receiver's exact average radiosity is `ρ F E` (the sphere
//! interior adds the receiver's view of itself in closed form). `F` comes from the
//! catalogue's closed forms where Howell gives one for the whole configuration (C-11,
//! C-14, C-41), and otherwise from the closed form of a differential element (B-3,
//! B-13, or Lambert's point-to-polygon formula) integrated over the receiver by a
//! graded composite Gauss–Legendre rule written here, independent of the solver's
//! quadrature and of `wavelux-geometry`'s contour integral.
//!
//! Tolerances of the issue: regular configurations 0.1 %, extremes 0.5 %, at the
//! command's default settings ([`default_settings`]).

use std::f64::consts::PI;

use wavelux::geometry::formfactor::{
    coaxial_disks, parallel_rectangles, perpendicular_rectangles, point_to_parallel_disk,
    point_to_parallel_rectangle_corner,
};
use wavelux::param::glam::DVec3;
use wavelux::quadrature::GaussLegendre;
use wavelux::scene::{Scene, parse_native};
use wavelux::solver::{BasisKind, LinearMethod, Solution, SolverConfig};

/// Exitance of every catalogue emitter (W/m²).
pub const EMISSION: f64 = 1.0;
/// Reflectance of every catalogue receiver.
pub const RHO: f64 = 0.5;
/// Relative tolerance of regular configurations (issue 11 §2).
pub const TOL_REGULAR: f64 = 1e-3;
/// Relative tolerance of extreme configurations (issue 11 §2).
pub const TOL_EXTREME: f64 = 5e-3;

/// The catalogue family of a case.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Family {
    /// C-11: directly opposed parallel rectangles.
    C11,
    /// C-14: perpendicular rectangles with a common edge (and other dihedral angles).
    C14,
    /// C-41: coaxial parallel disks.
    C41,
    /// B-3: a small receiver under the corner of a parallel rectangle.
    B3,
    /// B-13: a small receiver under a parallel disk, off its axis.
    B13,
    /// The interior of a sphere (a cap emits, the rest receives and sees itself).
    Sphere,
    /// Lights partly or wholly inside one receiver element, coplanar touching
    /// receivers, T-junctions.
    Junction,
}

impl Family {
    /// Howell's label (or ours for the junction cases).
    pub fn label(self) -> &'static str {
        match self {
            Self::C11 => "C-11",
            Self::C14 => "C-14",
            Self::C41 => "C-41",
            Self::B3 => "B-3",
            Self::B13 => "B-13",
            Self::Sphere => "sphere interior",
            Self::Junction => "junctions",
        }
    }
}

/// One catalogue configuration with its exact answer.
#[derive(Debug, Clone)]
pub struct Case {
    /// Family.
    pub family: Family,
    /// Short description, e.g. `"1×1 at c = 0.01"`.
    pub name: String,
    /// Whether the case is an extreme (tolerance [`TOL_EXTREME`], else [`TOL_REGULAR`]).
    pub extreme: bool,
    /// The scene as a native-format file.
    pub native: String,
    /// The measured receivers: surface name and exact average radiosity (W/m²).
    pub receivers: Vec<(String, f64)>,
    /// The exact form factor of the first receiver to the emitter (for the table).
    pub form_factor: f64,
}

impl Case {
    /// The scene, parsed from [`Case::native`].
    ///
    /// # Errors
    /// Loader errors (none for the catalogue's own text).
    pub fn scene(&self) -> anyhow::Result<Scene> {
        let s = parse_native(&self.native, &format!("<catalogue {}>", self.name), None)?;
        s.validate(&self.name)?;
        Ok(s)
    }

    /// The relative tolerance of the case.
    pub fn tolerance(&self) -> f64 {
        if self.extreme {
            TOL_EXTREME
        } else {
            TOL_REGULAR
        }
    }
}

/// The `wavelux solve` command's default gathering settings (docs/cli.md): M3,
/// `ε = 1e-2`, deepest level 2, GMRES(30) to a relative residual of 1e-6, 3 Gauss
/// points per axis, visibility in quadrature.
pub fn default_settings() -> SolverConfig {
    SolverConfig {
        basis: BasisKind::Multiwavelet(3),
        eps: 1e-2,
        max_level: 2,
        linear_method: LinearMethod::Gmres { restart: 30 },
        max_iterations: 100,
        tolerance: 1e-6,
        ..SolverConfig::default()
    }
}

/// Real-area average radiosity (first channel) of the lit sides of a surface: the sides
/// that reflect or emit (the inside of a sphere is the back side of its surface).
///
/// # Panics
/// If `surface` is out of range.
pub fn lit_average(sol: &Solution, surface: usize) -> f64 {
    sol.lit_average(surface)[0]
}

// ---------------------------------------------------------------------------------
// Native-format text
// ---------------------------------------------------------------------------------

fn v3(p: DVec3) -> String {
    format!("[{:?}, {:?}, {:?}]", p.x, p.y, p.z)
}

const MATERIALS: &str = "[[material]]\nname = \"lamp\"\nreflectance = 0.0\nemission = 1.0\n\n\
                         [[material]]\nname = \"white\"\nreflectance = 0.5\n\n";

/// The head of a catalogue scene: its name and the materials `lamp` (black, E = 1)
/// and `white` (ρ = 0.5).
pub fn header(name: &str) -> String {
    format!("name = {name:?}\n\n{MATERIALS}")
}

/// A `[[surface]]` parallelogram `origin + s·eu + t·ev` (front side `eu × ev`).
pub fn quad(name: &str, material: &str, origin: DVec3, eu: DVec3, ev: DVec3) -> String {
    format!(
        "[[surface]]\nname = {name:?}\nmaterial = {material:?}\nshape = {{ type = \"parallelogram\", origin = {}, edge_u = {}, edge_v = {} }}\n\n",
        v3(origin),
        v3(eu),
        v3(ev)
    )
}

/// A disk of radius `r` around `c` in the plane spanned by the unit vectors `u`, `v`
/// (front side `u × v`): a polygon whose outer loop is one full circle.
fn disk(name: &str, material: &str, c: DVec3, u: DVec3, v: DVec3, r: f64) -> String {
    format!(
        "[[surface]]\nname = {name:?}\nmaterial = {material:?}\n[surface.shape]\ntype = \"polygon\"\norigin = {}\nu = {}\nv = {}\nouter = [{{ start = [{r:?}, 0.0], center = [0.0, 0.0], ccw = true }}]\n\n",
        v3(c),
        v3(u),
        v3(v)
    )
}

// ---------------------------------------------------------------------------------
// Independent exact values
// ---------------------------------------------------------------------------------

/// Lambert's point-to-polygon form factor (unoccluded; the polygon must lie in the
/// closed half-space in front of the point), written independently of
/// `wavelux-geometry`.
pub fn lambert(x: DVec3, n: DVec3, poly: &[DVec3]) -> f64 {
    let mut sum = 0.0;
    for i in 0..poly.len() {
        let a = (poly[i] - x).normalize();
        let b = (poly[(i + 1) % poly.len()] - x).normalize();
        let c = a.cross(b);
        let s = c.length();
        if s == 0.0 {
            continue;
        }
        sum += a.dot(b).clamp(-1.0, 1.0).acos() * n.dot(c / s);
    }
    (sum / (2.0 * PI)).abs()
}

/// Nodes and weights on `[0, 1]` of a composite Gauss–Legendre rule graded
/// geometrically (ratio 0.15, down to 1e-14) towards both ends: exact enough (~1e-12)
/// for integrands with logarithmic end-point behaviour, as a point form factor has
/// where the receiver touches the emitter.
pub fn graded_rule() -> (Vec<f64>, Vec<f64>) {
    let (x, w) = GaussLegendre::new(12).expect("order 12").unit();
    let mut pts = Vec::new();
    let mut wts = Vec::new();
    let mut panel = |a: f64, b: f64| {
        for (xi, wi) in x.iter().zip(&w) {
            pts.push(a + (b - a) * xi);
            wts.push((b - a) * wi);
        }
    };
    // [0, 0.5] graded towards 0, [0.5, 1] towards 1.
    let mut edges = vec![0.5];
    while *edges.last().unwrap() > 1e-14 {
        let d = edges.last().unwrap() * 0.15;
        edges.push(d);
    }
    edges.push(0.0);
    for w2 in edges.windows(2) {
        panel(w2[1], w2[0]);
        panel(1.0 - w2[0], 1.0 - w2[1]);
    }
    (pts, wts)
}

/// `(1/|R|) ∫_R f(x) dA` over the parallelogram `o + s·eu + t·ev` with the graded
/// tensor rule.
fn receiver_average(o: DVec3, eu: DVec3, ev: DVec3, f: &dyn Fn(DVec3) -> f64) -> f64 {
    let (x, w) = graded_rule();
    let mut sum = 0.0;
    for (s, ws) in x.iter().zip(&w) {
        for (t, wt) in x.iter().zip(&w) {
            sum += ws * wt * f(o + *s * eu + *t * ev);
        }
    }
    sum
}

/// `F(R → E)` of two parallelograms `[origin, edge_u, edge_v]` (unoccluded) by
/// Lambert's formula integrated over `R` with the graded rule (~1e-12).
pub fn quad_to_quad(r: [DVec3; 3], e: [DVec3; 3]) -> f64 {
    let [o, eu, ev] = r;
    let n = eu.cross(ev).normalize();
    let poly = [e[0], e[0] + e[1], e[0] + e[1] + e[2], e[0] + e[2]];
    receiver_average(o, eu, ev, &|x| lambert(x, n, &poly))
}

/// B-3 at an arbitrary point below the plane of an axis-aligned rectangle
/// `[x0, x1] × [y0, y1]` at height `c`, by superposition of corner rectangles (signed
/// areas), for a receiver facing the rectangle.
fn b3_anywhere(px: f64, py: f64, x0: f64, x1: f64, y0: f64, y1: f64, c: f64) -> f64 {
    // F to the rectangle [0, X] × [0, Y] with the point under the origin corner, for
    // signed X, Y (sign flips the contribution).
    let corner = |dx: f64, dy: f64| -> f64 {
        if dx == 0.0 || dy == 0.0 {
            return 0.0;
        }
        let v = point_to_parallel_rectangle_corner(dx.abs(), dy.abs(), c).expect("valid");
        v * dx.signum() * dy.signum()
    };
    corner(x1 - px, y1 - py) - corner(x0 - px, y1 - py) - corner(x1 - px, y0 - py)
        + corner(x0 - px, y0 - py)
}

// ---------------------------------------------------------------------------------
// The cases
// ---------------------------------------------------------------------------------

fn case(
    family: Family,
    name: impl Into<String>,
    extreme: bool,
    native: String,
    receivers: Vec<(String, f64)>,
) -> Case {
    let form_factor = receivers[0].1 / (RHO * EMISSION);
    Case {
        family,
        name: name.into(),
        extreme,
        native,
        receivers,
        form_factor,
    }
}

/// C-11: `a × b` rectangles at distance `c`, scaled by `scale`; receiver below
/// (facing +z), emitter above (facing −z).
fn c11(a: f64, b: f64, c: f64, scale: f64, extreme: bool) -> Case {
    let f = parallel_rectangles(a, b, c).expect("valid");
    let mut t = header("c11");
    let (x, y, z) = (DVec3::X * scale, DVec3::Y * scale, DVec3::Z * scale);
    t += &quad("receiver", "white", DVec3::ZERO, a * x, b * y);
    t += &quad("emitter", "lamp", c * z, b * y, a * x);
    let name = if scale == 1.0 {
        format!("{a}×{b} at c = {c}")
    } else {
        format!("{a}×{b} at c = {c}, scale {scale:e}")
    };
    case(
        Family::C11,
        name,
        extreme,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// C-14: common edge `l` along x; receiver of width `w` in the floor (facing +z),
/// emitter of height `h` in the wall y = 0 (facing +y), scaled by `scale`.
fn c14(l: f64, w: f64, h: f64, scale: f64, extreme: bool) -> Case {
    let f = perpendicular_rectangles(l, w, h).expect("valid");
    let mut t = header("c14");
    let (x, y, z) = (DVec3::X * scale, DVec3::Y * scale, DVec3::Z * scale);
    t += &quad("receiver", "white", DVec3::ZERO, l * x, w * y);
    t += &quad("emitter", "lamp", DVec3::ZERO, h * z, l * x);
    let name = if scale == 1.0 {
        format!("l = {l}, w = {w}, h = {h}")
    } else {
        format!("l = {l}, w = {w}, h = {h}, scale {scale:e}")
    };
    case(
        Family::C14,
        name,
        extreme,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// Two unit squares with a common edge (along x) at dihedral angle `deg`: receiver in
/// the floor, emitter rotated about the x axis; Lambert's formula over the receiver.
fn dihedral(deg: f64) -> Case {
    let th = deg.to_radians();
    // Emitter edge direction away from the common edge, in the yz plane.
    let d = DVec3::new(0.0, th.cos(), th.sin());
    let r = [DVec3::ZERO, DVec3::X, DVec3::Y];
    // Emitter front faces the receiver: edge_u × edge_v points into the wedge.
    let e = [DVec3::ZERO, d, DVec3::X];
    let f = quad_to_quad(r, e);
    let mut t = header("dihedral");
    t += &quad("receiver", "white", r[0], r[1], r[2]);
    t += &quad("emitter", "lamp", e[0], e[1], e[2]);
    case(
        Family::C14,
        format!("unit squares at a dihedral angle of {deg}°"),
        !(60.0..=120.0).contains(&deg),
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// C-41: coaxial disks, receiver of radius `r1` at the origin (facing +z), emitter of
/// radius `r2` at height `h` (facing −z).
fn c41(r1: f64, r2: f64, h: f64, extreme: bool) -> Case {
    let f = coaxial_disks(r1, r2, h).expect("valid");
    let mut t = header("c41");
    t += &disk("receiver", "white", DVec3::ZERO, DVec3::X, DVec3::Y, r1);
    t += &disk("emitter", "lamp", h * DVec3::Z, DVec3::Y, DVec3::X, r2);
    case(
        Family::C41,
        format!("r1 = {r1}, r2 = {r2}, h = {h}"),
        extreme,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// B-3: a `d × d` receiver centred under the corner `(0, 0)` of the `a × b` emitter
/// `[0, a] × [0, b]` at height `c`; B-3's closed form averaged over the receiver.
fn b3(a: f64, b: f64, c: f64, d: f64, extreme: bool) -> Case {
    let o = DVec3::new(-0.5 * d, -0.5 * d, 0.0);
    let f = receiver_average(o, d * DVec3::X, d * DVec3::Y, &|p| {
        b3_anywhere(p.x, p.y, 0.0, a, 0.0, b, c)
    });
    let mut t = header("b3");
    t += &quad("receiver", "white", o, d * DVec3::X, d * DVec3::Y);
    t += &quad("emitter", "lamp", c * DVec3::Z, b * DVec3::Y, a * DVec3::X);
    case(
        Family::B3,
        format!("{d} receiver under the corner of {a}×{b} at c = {c}"),
        extreme,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// B-13: a `d × d` receiver centred at radial offset `a` under a disk of radius `r` at
/// height `h`; B-13's closed form averaged over the receiver.
fn b13(r: f64, h: f64, a: f64, d: f64, extreme: bool) -> Case {
    let o = DVec3::new(a - 0.5 * d, -0.5 * d, 0.0);
    let f = receiver_average(o, d * DVec3::X, d * DVec3::Y, &|p| {
        point_to_parallel_disk(r, h, p.truncate().length()).expect("valid")
    });
    let mut t = header("b13");
    t += &quad("receiver", "white", o, d * DVec3::X, d * DVec3::Y);
    t += &disk("emitter", "lamp", h * DVec3::Z, DVec3::Y, DVec3::X, r);
    case(
        Family::B13,
        format!("{d} receiver at offset {a} under a disk r = {r} at h = {h}"),
        extreme,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// The inside of a unit sphere: the cap above latitude `lat` emits, the rest (facing
/// inwards) receives. Every point of a sphere sees every other with `G = 1/(4πR²)`,
/// so the receiver's radiosity is uniform:
/// `B = ρ (E A_cap + B A_rest)/A` ⇒ `B = ρ E (A_cap/A) / (1 − ρ A_rest/A)`.
fn sphere(lat: f64, extreme: bool) -> Case {
    let cap = 0.5 * (1.0 - lat.to_radians().sin());
    let b = RHO * EMISSION * cap / (1.0 - RHO * (1.0 - cap));
    let mut t = header("sphere");
    t += "[[material]]\nname = \"black\"\nreflectance = 0.0\n\n";
    let patch = |name: &str, back: &str, lo: f64, hi: f64| {
        format!(
            "[[surface]]\nname = {name:?}\nmaterial = \"black\"\nback_material = {back:?}\nshape = {{ type = \"sphere\", center = [0.0, 0.0, 0.0], radius = 1.0, axis = [0.0, 0.0, 1.0], latitude_deg = [{lo:?}, {hi:?}] }}\n\n"
        )
    };
    t += &patch("receiver", "white", -90.0, lat);
    t += &patch("emitter", "lamp", lat, 90.0);
    let mut c = case(
        Family::Sphere,
        format!("cap above latitude {lat}° emits into the rest"),
        extreme,
        t,
        vec![("receiver".into(), b)],
    );
    c.form_factor = cap;
    c
}

/// A 0.05 × 0.05 lamp at height 0.1 over an off-centre point of a unit receiver: the
/// light lies wholly inside one receiver element.
fn light_inside() -> Case {
    let r = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let e = [
        DVec3::new(0.3, 0.35, 0.1),
        DVec3::new(0.0, 0.05, 0.0),
        DVec3::new(0.05, 0.0, 0.0),
    ];
    let f = quad_to_quad(r, e);
    let mut t = header("light-inside");
    t += &quad("receiver", "white", r[0], r[1], r[2]);
    t += &quad("emitter", "lamp", e[0], e[1], e[2]);
    case(
        Family::Junction,
        "0.05 lamp at height 0.1 over a unit receiver",
        true,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// Two coplanar touching receivers (1 × 1 and 0.25 × 0.25 sharing part of an edge: a
/// T-junction of supports of different sizes) under a 0.2 × 0.2 lamp at height 0.15
/// straddling their common edge (the light is partly inside each).
fn light_straddling() -> Case {
    let big = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let small = [DVec3::new(1.0, 0.4, 0.0), 0.25 * DVec3::X, 0.25 * DVec3::Y];
    let e = [
        DVec3::new(0.9, 0.42, 0.15),
        DVec3::new(0.0, 0.2, 0.0),
        DVec3::new(0.2, 0.0, 0.0),
    ];
    let mut t = header("light-straddling");
    t += &quad("big", "white", big[0], big[1], big[2]);
    t += &quad("small", "white", small[0], small[1], small[2]);
    t += &quad("emitter", "lamp", e[0], e[1], e[2]);
    case(
        Family::Junction,
        "0.2 lamp at 0.15 over coplanar receivers 1×1 and 0.25×0.25 (T-junction)",
        true,
        t,
        vec![
            ("big".into(), RHO * EMISSION * quad_to_quad(big, e)),
            ("small".into(), RHO * EMISSION * quad_to_quad(small, e)),
        ],
    )
}

/// A unit floor receiver and a 0.5 × 0.5 wall emitter standing on part of the floor's
/// edge (a partial common edge: T-junction between a full and a half edge).
fn t_junction() -> Case {
    let r = [DVec3::ZERO, DVec3::X, DVec3::Y];
    let e = [DVec3::new(0.25, 0.0, 0.0), 0.5 * DVec3::Z, 0.5 * DVec3::X];
    let f = quad_to_quad(r, e);
    let mut t = header("t-junction");
    t += &quad("receiver", "white", r[0], r[1], r[2]);
    t += &quad("emitter", "lamp", e[0], e[1], e[2]);
    case(
        Family::Junction,
        "unit floor, 0.5 wall lamp on the middle of its edge",
        true,
        t,
        vec![("receiver".into(), RHO * EMISSION * f)],
    )
}

/// Every case of the catalogue.
pub fn cases() -> Vec<Case> {
    let mut v = vec![
        c11(1.0, 1.0, 1.0, 1.0, false),
        c11(1.0, 1.0, 0.01, 1.0, true),
        c11(1.0, 1.0, 100.0, 1.0, true),
        c11(1.0, 1.0, 178.0, 1.0, true),
        c11(1.0, 10.0, 0.5, 1.0, true),
        c11(1.0, 1.0, 1.0, 1e-4, true),
        c11(1.0, 1.0, 1.0, 1e4, true),
        c14(1.0, 1.0, 1.0, 1.0, false),
        c14(1.0, 0.01, 1.0, 1.0, true),
        c14(1.0, 1.0, 0.01, 1.0, true),
        c14(1.0, 0.01, 0.01, 1.0, true),
        c14(0.01, 1.0, 1.0, 1.0, true),
        c14(1.0, 1.0, 1.0, 1e-4, true),
        c14(1.0, 1.0, 1.0, 1e4, true),
    ];
    v.extend([10.0, 30.0, 60.0, 120.0, 170.0].map(dihedral));
    v.extend([
        c41(1.0, 1.0, 1.0, false),
        c41(1.0, 1.0, 0.01, true),
        c41(1.0, 1.0, 100.0, true),
        c41(0.1, 1.0, 1.0, true),
        c41(1.0, 0.1, 1.0, true),
        b3(1.0, 1.0, 1.0, 0.01, false),
        b3(100.0, 100.0, 1.0, 0.01, true),
        b3(10.0, 0.1, 1.0, 0.01, true),
        b3(2.0, 1.0, 0.5, 0.01, true),
        b13(1.0, 1.0, 0.0, 0.01, false),
        b13(1.0, 1.0, 2.0, 0.01, true),
        b13(1.0, 0.1, 0.99, 0.01, true),
        b13(100.0, 1.0, 0.0, 0.01, true),
        sphere(60.0, false),
        sphere(85.0, true),
        light_inside(),
        light_straddling(),
        t_junction(),
    ]);
    v
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lambert_quadrature_reproduces_the_closed_forms() {
        // C-11 and C-14 by Lambert's formula over the receiver vs Howell's closed forms.
        let c11 = quad_to_quad(
            [DVec3::ZERO, DVec3::X, 2.0 * DVec3::Y],
            [DVec3::new(0.0, 0.0, 0.5), 2.0 * DVec3::Y, DVec3::X],
        );
        let exact = parallel_rectangles(1.0, 2.0, 0.5).unwrap();
        assert!((c11 - exact).abs() < 1e-10 * exact, "{c11} vs {exact}");
        let c14 = quad_to_quad(
            [DVec3::ZERO, DVec3::X, 0.01 * DVec3::Y],
            [DVec3::ZERO, DVec3::Z, DVec3::X],
        );
        let exact = perpendicular_rectangles(1.0, 0.01, 1.0).unwrap();
        assert!((c14 - exact).abs() < 1e-9 * exact, "{c14} vs {exact}");
    }

    #[test]
    fn every_case_parses_and_its_exact_value_is_a_form_factor() {
        for c in cases() {
            let s = c.scene().unwrap();
            for (r, b) in &c.receivers {
                assert!(s.surface(r).is_some(), "{}: {r}", c.name);
                let f = b / (RHO * EMISSION);
                assert!(f > 0.0 && f < 1.0, "{}: F = {f}", c.name);
            }
        }
    }
}
