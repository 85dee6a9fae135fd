//! Glossy §7.2, Fig. 16: a maze with a glossy teapot, spotlights and a window showing
//! an outdoor image, rendered from an eye patch in the hallway.
//!
//! Paper (seed 003, §7.2): 152 patches including the 28 bicubic Bézier patches of the
//! teapot (the 32-patch Utah teapot minus its bottom), 24 spotlights and a window
//! "emitting" a scanned outdoor image; teapot Ward `α = (0.2, 0.5)`, `ρ_s = 0.1`,
//! `ρ_d = (0.2, 0.15, 0)`. 12,603 visible pairs are the initial links; after six
//! rounds 126 / 1,518 / 18,852 / 160,248 / 165,495 coefficients in `V⁰`, `W⁰`–`W³`
//! and ≈ 1.73 M links (links × 137); on a DEC 3000/400 the initial solution took
//! 5 min, refining 100 min, a 600² image by direct evaluation 15 min, the final gather
//! ≈ 2 h.
//!
//! Ours: the scene is rebuilt from the paper's description (its geometry file is not
//! in the seed text), see [`maze_teapot`]: a 8 × 6 × 2.5 m maze of 2 m cells (floor
//! tiles, ceiling tiles, outer walls, 12 two-sided interior walls), 24 cosine-power
//! spotlights under the ceiling, a window at the hallway's end emitting a procedural
//! outdoor image (sky, sun, hills), a rug, and a teapot of 28 bicubic Bézier patches in
//! the Utah teapot's layout (rim 4, body 8, lid 8, handle 4, spout 4) whose profile
//! and tube control points are ours. The camera stands in the hallway looking through
//! a doorway at the teapot. We count lit sides as patches (152 without the eye), run
//! the glossy method without and with importance from the eye for the same rounds,
//! and measure every image against the glossy path tracer's image of the same view.

use super::glossy_3_5::Curve;
use super::glossy_fig13::PAPER_MAP;
use crate::cpu::Stopwatch;
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use rand_pcg::Pcg64;
use std::f64::consts::{FRAC_PI_2, PI};
use wavelux::geometry::{Accel, Hit};
use wavelux::glossy::{
    GatherMode, GlossyConfig, GlossyScene, GlossySolution, ImportanceSource, TransportOptions,
    WardVariant,
};
use wavelux::param::glam::DVec3;
use wavelux::render::{
    GlossyField, GlossyTracer, Image, RadianceField, RadianceOptions, ReferenceOptions, ToneMap,
    TracedRadiance, View, render_radiance,
};
use wavelux::scene::{
    BezierPatch, Camera, EmissionProfile, Material, Rgb, Scene, Shape, Sidedness, Surface, Texture,
    TextureRef, WardParams,
};

/// Cell side of the maze (m).
const CELL: f64 = 2.0;
/// Maze size in cells (x, y).
const COLS: usize = 4;
const ROWS: usize = 3;
/// Ceiling height (m).
const HEIGHT: f64 = 2.5;
/// Spotlight side (m), exitance (W/m²) and cosine exponent.
const SPOT_SIDE: f64 = 0.12;
const SPOT_EXITANCE: f64 = 100.0;
const SPOT_EXPONENT: f64 = 8.0;
/// Window exitance scale (W/m², times the outdoor image).
const WINDOW_EXITANCE: f64 = 30.0;
/// Teapot scale (teapot units to m) and centre on the floor.
const TEAPOT_SCALE: f64 = 0.22;
const TEAPOT_AT: [f64; 2] = [3.0, 3.0];

/// `4/3 · tan(π/8)`: the inner control-point distance of a cubic quarter circle.
const QUARTER: f64 = 0.552_284_749_830_793_4;

/// Profile segments `(radius, height)` of the teapot's body of revolution, in teapot
/// units (z up, height 3.15): rim, upper body, lower body, lid knob, lid. Each runs from
/// the top / inside to the bottom / outside, so that `∂P/∂u × ∂P/∂v` faces out.
const PROFILES: [(&str, [[f64; 2]; 4]); 5] = [
    (
        "rim",
        [[1.4, 2.4], [1.3375, 2.531], [1.4375, 2.531], [1.5, 2.4]],
    ),
    (
        "body-upper",
        [[1.5, 2.4], [1.75, 1.875], [2.0, 1.35], [2.0, 0.9]],
    ),
    (
        "body-lower",
        [[2.0, 0.9], [2.0, 0.45], [1.5, 0.225], [1.5, 0.15]],
    ),
    ("knob", [[0.0, 3.15], [0.8, 3.15], [0.0, 2.85], [0.2, 2.7]]),
    ("lid", [[0.2, 2.7], [0.4, 2.55], [1.4, 2.55], [1.4, 2.4]]),
];

/// Tubes (handle, spout): two centre-curve segments in the xz plane, each with the
/// half-widths across (along y) and in the plane at its four control points.
type Tube = (&'static str, [[f64; 3]; 4], [f64; 4], [f64; 4]);
const TUBES: [Tube; 4] = [
    (
        "handle-upper",
        [
            [-1.5, 0.0, 2.1],
            [-2.3, 0.0, 2.25],
            [-2.9, 0.0, 2.1],
            [-2.9, 0.0, 1.65],
        ],
        [0.25; 4],
        [0.12; 4],
    ),
    (
        "handle-lower",
        [
            [-2.9, 0.0, 1.65],
            [-2.9, 0.0, 1.1],
            [-2.5, 0.0, 0.8],
            [-1.8, 0.0, 0.6],
        ],
        [0.25; 4],
        [0.12; 4],
    ),
    (
        "spout-lower",
        [
            [1.5, 0.0, 1.2],
            [2.4, 0.0, 1.2],
            [2.4, 0.0, 1.8],
            [2.6, 0.0, 2.1],
        ],
        [0.4, 0.35, 0.3, 0.25],
        [0.4, 0.35, 0.3, 0.25],
    ),
    (
        "spout-upper",
        [
            [2.6, 0.0, 2.1],
            [2.75, 0.0, 2.35],
            [2.95, 0.0, 2.45],
            [3.2, 0.0, 2.45],
        ],
        [0.25, 0.2, 0.18, 0.15],
        [0.25, 0.2, 0.18, 0.15],
    ),
];

/// The 28 bicubic patches of the teapot (teapot units), named, control points
/// `ctrl[i][j]` with `i` along `u` and `j` along `v`; fronts face out.
pub(super) fn teapot_patches() -> Vec<(String, [[DVec3; 4]; 4])> {
    let mut out = Vec::with_capacity(28);
    for (name, prof) in PROFILES {
        for q in 0..4 {
            let a0 = q as f64 * FRAC_PI_2;
            let a1 = a0 + FRAC_PI_2;
            let e = |a: f64| DVec3::new(a.cos(), a.sin(), 0.0);
            let de = |a: f64| DVec3::new(-a.sin(), a.cos(), 0.0);
            let ctrl = prof.map(|[r, z]| {
                let h = DVec3::new(0.0, 0.0, z);
                [
                    h + r * e(a0),
                    h + r * (e(a0) + QUARTER * de(a0)),
                    h + r * (e(a1) - QUARTER * de(a1)),
                    h + r * e(a1),
                ]
            });
            out.push((format!("teapot.{name}.{q}"), ctrl));
        }
    }
    for (name, centre, across, inplane) in TUBES {
        let c = centre.map(DVec3::from_array);
        for sign in [1.0, -1.0] {
            let ctrl: [[DVec3; 4]; 4] = std::array::from_fn(|i| {
                let t = (c[(i + 1).min(3)] - c[i.max(1) - 1]).normalize();
                // In-plane normal of the centre curve (y × t) and the across axis.
                let n = DVec3::Y.cross(t);
                let (b, h) = (DVec3::Y * across[i], n * (sign * inplane[i] * 4.0 / 3.0));
                // A cubic half ellipse from +b to −b bulging along ±n; the lower half
                // runs from −b to +b so that both fronts face away from the curve.
                let (p, q) = if sign > 0.0 { (b, -b) } else { (-b, b) };
                [c[i] + p, c[i] + p + h, c[i] + q + h, c[i] + q]
            });
            let half = if sign > 0.0 { "a" } else { "b" };
            out.push((format!("teapot.{name}.{half}"), ctrl));
        }
    }
    out
}

/// A rectangle of `w × h` centred at `c`, front normal `n`, `w` along the unit `u`
/// (`v = n × u`).
#[allow(clippy::too_many_arguments)]
fn rect(s: &mut Scene, name: &str, c: DVec3, n: DVec3, u: DVec3, w: f64, h: f64, mat: usize) {
    rect_sided(s, name, c, n, u, (w, h), mat, Sidedness::OneSided);
}

#[allow(clippy::too_many_arguments)]
fn rect_sided(
    s: &mut Scene,
    name: &str,
    c: DVec3,
    n: DVec3,
    u: DVec3,
    (w, h): (f64, f64),
    mat: usize,
    sides: Sidedness,
) {
    let (eu, ev) = (u * w, n.cross(u) * h);
    s.add_surface(Surface {
        name: name.into(),
        shape: Shape::Parallelogram {
            origin: c - 0.5 * (eu + ev),
            edge_u: eu,
            edge_v: ev,
        },
        material: mat,
        sides,
    });
}

/// The window's outdoor image (`w × h` texels, row `r` at height `t = (r + ½)/h`
/// above the sill — the support's `t` runs upward): sky brightening toward the
/// horizon, a sun, green hills.
fn outdoor_image(w: usize, h: usize) -> Texture {
    let texels = (0..w * h)
        .map(|i| {
            let (s, t) = (
                ((i % w) as f64 + 0.5) / w as f64,
                ((i / w) as f64 + 0.5) / h as f64,
            );
            let horizon = 0.35 + 0.08 * (3.0 * PI * s).sin();
            if t < horizon {
                let d = t / horizon;
                Rgb([0.08 + 0.1 * d, 0.2 + 0.2 * d, 0.05 + 0.05 * d])
            } else if (s - 0.75).hypot(t - 0.8) < 0.07 {
                Rgb([4.0, 3.6, 2.5])
            } else {
                let d = (t - horizon) / (1.0 - horizon);
                Rgb([0.65 - 0.4 * d, 0.78 - 0.33 * d, 1.0 - 0.1 * d])
            }
        })
        .collect();
    Texture {
        name: "outdoor".into(),
        width: w,
        height: h,
        texels,
    }
}

/// The maze with the teapot (module docs) and the hallway camera.
///
/// # Errors
/// If the camera is degenerate (never for these constants).
pub(super) fn maze_teapot() -> anyhow::Result<(Scene, Camera)> {
    let mut s = Scene::new("glossy-fig16");
    let floor = s.add_material(Material::lambertian("floor", Rgb::grey(0.5), Rgb::BLACK));
    let ceiling = s.add_material(Material::lambertian("ceiling", Rgb::grey(0.7), Rgb::BLACK));
    let wall = s.add_material(Material::lambertian(
        "wall",
        Rgb([0.6, 0.58, 0.5]),
        Rgb::BLACK,
    ));
    let rug = s.add_material(Material::lambertian(
        "rug",
        Rgb([0.5, 0.1, 0.1]),
        Rgb::BLACK,
    ));
    let mut spot = Material::lambertian("spotlight", Rgb::BLACK, Rgb::grey(SPOT_EXITANCE));
    spot.emission_profile = EmissionProfile::CosinePower {
        exponent: SPOT_EXPONENT,
    };
    let spot = s.add_material(spot);
    s.textures.push(outdoor_image(32, 16));
    let mut window = Material::lambertian("window", Rgb::BLACK, Rgb::grey(WINDOW_EXITANCE));
    window.emission_texture = Some(TextureRef {
        texture: s.textures.len() - 1,
        uv_set: 0,
    });
    let window = s.add_material(window);
    let mut glaze = Material::lambertian("teapot", Rgb([0.2, 0.15, 0.0]), Rgb::BLACK);
    glaze.ward = Some(WardParams {
        specular: Rgb::grey(0.1),
        alpha_x: 0.2,
        alpha_y: 0.5,
    });
    let glaze = s.add_material(glaze);

    let (x, y, z) = (DVec3::X, DVec3::Y, DVec3::Z);
    for c in 0..COLS {
        for r in 0..ROWS {
            let (x0, y0) = (c as f64 * CELL, r as f64 * CELL);
            for k in 0..4 {
                let (dx, dy) = (0.5 + (k % 2) as f64, 0.5 + (k / 2) as f64);
                rect(
                    &mut s,
                    &format!("floor.{c}.{r}.{k}"),
                    DVec3::new(x0 + dx, y0 + dy, 0.0),
                    z,
                    x,
                    1.0,
                    1.0,
                    floor,
                );
            }
            let mid = DVec3::new(x0 + 1.0, y0 + 1.0, HEIGHT);
            rect(
                &mut s,
                &format!("ceiling.{c}.{r}"),
                mid,
                -z,
                y,
                CELL,
                CELL,
                ceiling,
            );
            for (k, dx) in [-0.5, 0.5].into_iter().enumerate() {
                rect(
                    &mut s,
                    &format!("spot.{c}.{r}.{k}"),
                    mid + DVec3::new(dx, 0.0, -0.01),
                    -z,
                    y,
                    SPOT_SIDE,
                    SPOT_SIDE,
                    spot,
                );
            }
        }
    }
    let wall_z = 0.5 * HEIGHT;
    for r in 0..ROWS {
        let yc = (r as f64 + 0.5) * CELL;
        let at = |xw: f64| DVec3::new(xw, yc, wall_z);
        rect(
            &mut s,
            &format!("wall.x0.{r}"),
            at(0.0),
            x,
            y,
            CELL,
            HEIGHT,
            wall,
        );
        let far = COLS as f64 * CELL;
        rect(
            &mut s,
            &format!("wall.x1.{r}"),
            at(far),
            -x,
            -y,
            CELL,
            HEIGHT,
            wall,
        );
    }
    for c in 0..COLS {
        let xc = (c as f64 + 0.5) * CELL;
        let at = |yw: f64| DVec3::new(xc, yw, wall_z);
        rect(
            &mut s,
            &format!("wall.y0.{c}"),
            at(0.0),
            y,
            -x,
            CELL,
            HEIGHT,
            wall,
        );
        let far = ROWS as f64 * CELL;
        rect(
            &mut s,
            &format!("wall.y1.{c}"),
            at(far),
            -y,
            x,
            CELL,
            HEIGHT,
            wall,
        );
    }
    // Interior walls, 1.4 m of every 2 m cell edge (a 0.6 m gap at alternating ends,
    // so every room is reachable): along y = 2 and y = 4 (full doorways at cell 1 of
    // y = 2, the teapot room's, and cell 3 of y = 4), across x = 2, 4, 6 in rows 1 and
    // 2; the hallway (row 0) is open end to end.
    let two = Sidedness::TwoSided { back: wall };
    let (inner, shift) = (CELL - 0.6, 0.3);
    let along_y = [(1, 0), (1, 2), (1, 3), (2, 0), (2, 1), (2, 2)];
    let across_x = [(1, 1), (1, 2), (2, 1), (2, 2), (3, 1), (3, 2)];
    for (k, (r, c)) in along_y.into_iter().enumerate() {
        let off = if k % 2 == 0 { shift } else { -shift };
        let at = DVec3::new((c as f64 + 0.5) * CELL + off, r as f64 * CELL, wall_z);
        let name = format!("inner.y{r}.{c}");
        rect_sided(&mut s, &name, at, y, -x, (inner, HEIGHT), wall, two);
    }
    for (k, (c, r)) in across_x.into_iter().enumerate() {
        let off = if k % 2 == 0 { -shift } else { shift };
        let at = DVec3::new(c as f64 * CELL, (r as f64 + 0.5) * CELL + off, wall_z);
        let name = format!("inner.x{c}.{r}");
        rect_sided(&mut s, &name, at, x, y, (inner, HEIGHT), wall, two);
    }
    let far = COLS as f64 * CELL;
    rect(
        &mut s,
        "window",
        DVec3::new(far - 0.005, 0.5 * CELL, 1.3),
        -x,
        -y,
        1.4,
        1.2,
        window,
    );
    let [tx, ty] = TEAPOT_AT;
    rect(
        &mut s,
        "rug",
        DVec3::new(tx, ty, 0.002),
        z,
        x,
        1.2,
        1.2,
        rug,
    );
    // The teapot, spout turned 30° toward the hallway, its open bottom 4 mm above the
    // floor.
    let (sin, cos) = (-PI / 6.0).sin_cos();
    let place = |p: DVec3| {
        let p = p * TEAPOT_SCALE;
        DVec3::new(
            tx + cos * p.x - sin * p.y,
            ty + sin * p.x + cos * p.y,
            p.z - 0.15 * TEAPOT_SCALE + 0.004,
        )
    };
    for (name, ctrl) in teapot_patches() {
        s.add_surface(Surface {
            name,
            shape: Shape::Bezier(BezierPatch {
                degree_u: 3,
                degree_v: 3,
                control: ctrl.iter().flatten().map(|&p| place(p)).collect(),
            }),
            material: glaze,
            sides: Sidedness::OneSided,
        });
    }
    let camera = Camera::look_at(
        "hallway",
        DVec3::new(tx, 0.35, 1.25),
        DVec3::new(tx, ty, 0.3),
        z,
        50f64.to_radians(),
        Some(4.0 / 3.0),
    )
    .ok_or_else(|| anyhow::anyhow!("degenerate hallway camera"))?;
    Ok((s, camera))
}

/// 1 where a primary ray hits an emitting patch, else 0 (the mask of
/// [`Image::reflected_relative_l1`]).
struct EmitterMask<'a>(&'a GlossyScene);

impl RadianceField for EmitterMask<'_> {
    fn accel(&self) -> &Accel {
        &self.0.accel
    }

    fn radiance(&self, hit: &Hit, _wo: DVec3, _rng: &mut Pcg64) -> Option<[f64; 3]> {
        let (p, _) = self.0.resolve(hit)?;
        Some(
            [if self.0.patches[p].is_emitter() {
                1.0
            } else {
                0.0
            }; 3],
        )
    }
}

/// One run (importance off or from the eye): per round the links, samples, seconds
/// and the image error against the tracer.
struct Run {
    sol: GlossySolution,
    curve: Curve,
    table: Vec<Vec<String>>,
    /// The last direct image.
    image: Image,
}

struct Setup<'a> {
    scene: &'a Scene,
    view: &'a View,
    /// The tracer's image box-filtered by `factor`, and the emitter mask likewise.
    reference: &'a Image,
    mask: &'a Image,
    factor: usize,
    rounds: usize,
    transport: TransportOptions,
    max_links: usize,
}

fn image_opts() -> RadianceOptions {
    RadianceOptions {
        spp: 2,
        seed: 7,
        back_face: [0.0; 3],
    }
}

fn run_one(st: &Setup<'_>, importance: ImportanceSource) -> anyhow::Result<Run> {
    let cfg = GlossyConfig {
        variant: WardVariant::Original,
        directions: PAPER_MAP,
        rounds: st.rounds,
        importance,
        transport: st.transport,
        max_links: st.max_links,
        ..GlossyConfig::default()
    };
    let t0 = Stopwatch::start();
    let mut sol = GlossySolution::new(st.scene, "glossy-fig16", cfg)?;
    let mut solve_secs = t0.elapsed().cpu_or_wall();
    let mut curve = Curve { points: Vec::new() };
    let mut table = Vec::new();
    let mut round = 0;
    let image = loop {
        let img = render_radiance(
            &GlossyField {
                solution: &sol,
                gather: None,
            },
            st.view,
            &image_opts(),
            &|_| {},
        )?;
        let (e, _) = img
            .downsample(st.factor)?
            .reflected_relative_l1(st.reference, st.mask)?;
        curve.points.push([
            sol.stats.links as f64,
            sol.stats.samples as f64,
            solve_secs,
            e,
        ]);
        table.push(vec![
            round.to_string(),
            sol.stats.links.to_string(),
            sol.stats.samples.to_string(),
            format!("{e:.4}"),
            format!("{solve_secs:.2}"),
        ]);
        if round == st.rounds {
            break img;
        }
        let t1 = Stopwatch::start();
        let Some(rs) = sol.refine_round()? else {
            break img;
        };
        solve_secs += t1.elapsed().cpu_or_wall();
        round = rs.round;
    };
    Ok(Run {
        sol,
        curve,
        table,
        image,
    })
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    let quick = ctx.quick;
    let rounds = if quick { 2 } else { 4 };
    let (w, h) = if quick { (48, 36) } else { (120, 90) };
    // Errors are measured on images box-filtered by this factor (the tracer's noise
    // falls by it), and the final gathers are rendered at that size.
    let factor = if quick { 4 } else { 2 };
    let half_spp = if quick { 4 } else { 12 };
    let gather_rays = if quick { 1 } else { 8 };
    let transport = if quick {
        TransportOptions {
            spatial: 1,
            ..TransportOptions::default()
        }
    } else {
        TransportOptions::default()
    };
    let max_links = if quick { 150_000 } else { 2_000_000 };
    r.param("refinement rounds (each run)", rounds);
    r.param("fraction", GlossyConfig::default().fraction);
    r.param(
        "transport samples (spatial n, angular m, lobe l)",
        format!(
            "{}, {}, {}",
            transport.spatial, transport.angular, transport.lobe
        ),
    );
    r.param("link cap", max_links);
    r.param(
        "image",
        format!(
            "{w} × {h}, 2 × 2 samples per pixel; errors on the images box-filtered to {} × {}",
            w / factor,
            h / factor
        ),
    );
    r.param(
        "tracer reference",
        format!(
            "{} paths per pixel, two independent halves",
            2 * half_spp * half_spp
        ),
    );
    r.param(
        "final gather",
        format!(
            "{gather_rays} rays per sending node, {} × {} image",
            w / factor,
            h / factor
        ),
    );
    r.param("Ward variant", "original (the paper's)");
    r.param("direction map", PAPER_MAP.name());
    r.paper_did = "Fig. 16: a maze of 152 patches (28 of them the bicubic Bézier patches of \
        the teapot without its bottom) lit by 24 spotlights and a window showing an \
        outdoor image, seen from an eye patch in the hallway; 12,603 visible pairs \
        (initial links), after six rounds 126 / 1,518 / 18,852 / 160,248 / 165,495 \
        coefficients in V⁰, W⁰–W³ and ≈ 1.73 M links; 5 min initial solution, 100 min \
        refining, 15 min for a 600² image by direct evaluation and ≈ 2 h for the final \
        gather on a DEC 3000/400."
        .into();
    r.we_did = "The scene is rebuilt from the description (the paper's files are not in \
        the seed): 2 m cells, 4 × 3, 2.5 m high; 48 floor tiles, 12 ceiling tiles, 14 \
        outer walls, 12 two-sided interior walls (24 patches), 24 cosine-power spotlights \
        (cos⁸, 0.12 m, under the ceiling), a 1.4 × 1.2 m window emitting a procedural \
        outdoor image at the hallway's end, a rug, and a teapot of 28 bicubic Bézier \
        patches in the Utah teapot's layout (rim 4, body 8, lid 8, handle 4, spout 4; \
        profiles and tubes ours, handle and spout not trimmed where they enter the \
        body) with the paper's Ward parameters. Patches are lit sides: 152 without the \
        eye. Two runs of the same rounds, importance off and from the eye patch \
        (§4.2); after every round the direct image of the solution (reflected expansion \
        plus exact emission) against the glossy path tracer's image of the same view \
        (relative L1 of the reflected radiance, pixels next to emitters left out), its \
        links and cumulative solve time; the time each run needs to reach the error \
        both reach (log–log between rounds). The three final gathers (§5.5) on the \
        importance solution: error and time against the direct image. Times are wall \
        times of this run on a shared 2-core machine."
        .into();

    let (scene, camera) = maze_teapot()?;
    let view = View::new(&camera, w, h)?;
    let traced = GlossyScene::new(
        &scene,
        "glossy-fig16",
        WardVariant::Original,
        &ImportanceSource::Off,
    )?;
    let tracer = GlossyTracer::new(&traced);
    let t_ref = Stopwatch::start();
    let halves: Vec<Image> = [11u64, 12]
        .into_iter()
        .map(|seed| {
            render_radiance(
                &TracedRadiance {
                    tracer: &tracer,
                    opts: ReferenceOptions {
                        seed,
                        ..ReferenceOptions::default()
                    },
                },
                &view,
                &RadianceOptions {
                    spp: half_spp,
                    seed,
                    back_face: [0.0; 3],
                },
                &|_| {},
            )
        })
        .collect::<Result<_, _>>()?;
    let ref_secs = t_ref.elapsed().cpu_or_wall();
    let mut reference = Image::new(w, h);
    for (i, p) in reference.pixels.iter_mut().enumerate() {
        *p = std::array::from_fn(|c| 0.5 * (halves[0].pixels[i][c] + halves[1].pixels[i][c]));
    }
    let mask = render_radiance(&EmitterMask(&traced), &view, &image_opts(), &|_| {})?;
    // Noise of the averaged reference: half the relative L1 between the halves. With
    // independent halves a = t + e₁, b = t + e₂ and symmetric noise, (e₁ − e₂)/2 has
    // the distribution of (e₁ + e₂)/2, the mean's noise: |a − b|/2 estimates it per
    // pixel. (Until session 29 this was divided by a further √2, which took
    // |a − mean| = |e₁ − e₂|/2 for one half's noise: it is the mean's.)
    let (ref_small, mask_small) = (reference.downsample(factor)?, mask.downsample(factor)?);
    let (split, kept) = halves[0]
        .downsample(factor)?
        .reflected_relative_l1(&halves[1].downsample(factor)?, &mask_small)?;
    let noise = split / 2.0;
    let setup = Setup {
        scene: &scene,
        view: &view,
        reference: &ref_small,
        mask: &mask_small,
        factor,
        rounds,
        transport,
        max_links,
    };
    let off = run_one(&setup, ImportanceSource::Off)?;
    let on = run_one(
        &setup,
        ImportanceSource::Camera {
            camera: camera.clone(),
            aspect: 4.0 / 3.0,
        },
    )?;

    // Counts against the paper's.
    let st = &off.sol.stats;
    let lit = off.sol.scene.patches.len();
    let bezier = scene
        .surfaces
        .iter()
        .filter(|s| matches!(s.shape, Shape::Bezier(_)))
        .count();
    let spots = off
        .sol
        .scene
        .patches
        .iter()
        .filter(|p| p.emission_exponent.is_some())
        .count();
    for (name, paper, ours) in [
        ("patches (lit sides, eye excluded)", 152.0, lit as f64),
        ("Bézier patches", 28.0, bezier as f64),
        ("spotlights", 24.0, spots as f64),
    ] {
        r.rows
            .push(Row::new(name, Some(paper), ours, "", Tolerance::Info));
    }
    let initial = off.curve.points[0][0];
    r.rows.push(
        Row::new(
            "visible pairs = initial links (ordered pairs)",
            Some(12_603.0),
            initial,
            "links",
            Tolerance::Info,
        )
        .comment(format!(
            "{} unordered pairs; the paper does not say whether its 12,603 counts \
             ordered or unordered pairs",
            st.visible_unordered
        )),
    );
    let spaces = st.spaces.clone();
    let paper_spaces = [126.0, 1_518.0, 18_852.0, 160_248.0, 165_495.0];
    for (j, paper) in paper_spaces.iter().enumerate() {
        let name = if j == 0 {
            "V⁰".to_string()
        } else {
            format!("W{}", ["⁰", "¹", "²", "³"][j - 1])
        };
        let ours = spaces.get(j).copied().unwrap_or(0) as f64;
        r.rows.push(
            Row::new(
                format!("non-zero radiance coefficients in {name} after the last round"),
                Some(*paper),
                ours,
                "",
                Tolerance::Info,
            )
            .comment(format!(
                "ours after {rounds} rounds (importance off), the paper's after six; \
                 V⁰ counts patches with any radiance (ours: every lit patch sees a light \
                 or a lit surface; the paper's 126 < 152 suggests its emitters' V⁰ or \
                 unlit patches were not counted — it does not say)"
            )),
        );
    }
    let last_links = st.links as f64;
    r.rows.push(Row::new(
        "links after the last round (importance off)",
        Some(1.73e6),
        last_links,
        "links",
        Tolerance::Info,
    ));
    r.rows.push(
        Row::new(
            "links after the last round / initial links",
            Some(137.0),
            last_links / initial,
            "",
            Tolerance::Info,
        )
        .comment(format!("ours after {rounds} rounds, the paper's after six")),
    );
    let t_initial = st.times.setup + st.times.initial_links + st.times.initial_solve;
    let t_refine = st.times.refine + st.times.solve;
    r.rows.push(
        Row::new(
            "refining time / initial solution time",
            Some(20.0),
            t_refine / t_initial,
            "",
            Tolerance::Info,
        )
        .comment(format!(
            "initial {t_initial:.2} s, refining {t_refine:.2} s ({rounds} rounds; the \
             solver's own wall-clock phase times); paper 5 min and 100 min (six rounds)"
        )),
    );
    let power = |p: [f64; 3]| p.iter().sum::<f64>();
    r.rows.push(
        Row::new(
            "|projected − exact| emitted power / exact (spotlights and window)",
            None,
            (power(st.emitted_power) - power(st.exact_emitted_power)).abs()
                / power(st.exact_emitted_power),
            "",
            Tolerance::Info,
        )
        .comment(format!(
            "exact {:.4} W; emitter level {}, cut-off {} (spotlights' cos⁸ cells by the \
             16-point cell rule, the window's image by 4 × 4 point samples per cell; \
             which of the two carries the difference is not analysed)",
            power(st.exact_emitted_power),
            GlossyConfig::default().emitter_level,
            GlossyConfig::default().emitter_tolerance
        )),
    );

    // Importance on vs off at equal image error.
    let headers = vec![
        "round".to_string(),
        "links".into(),
        "kernel samples (cumulative)".into(),
        "image relative L1 error".into(),
        "cumulative solve CPU s".into(),
    ];
    r.tables.push(Table {
        title: "Importance off: image error against the tracer per round".into(),
        headers: headers.clone(),
        rows: off.table.clone(),
    });
    r.tables.push(Table {
        title: "Importance from the eye patch: image error against the tracer per round".into(),
        headers,
        rows: on.table.clone(),
    });
    r.rows.push(
        Row::new(
            "tracer reference noise (relative L1 of the averaged image)",
            None,
            noise,
            "",
            Tolerance::Info,
        )
        .comment(format!(
            "{kept} pixels kept of {}; reference {ref_secs:.1} CPU s",
            w * h
        )),
    );
    let e_off = off.curve.points.iter().map(|p| p[3]).collect::<Vec<_>>();
    let e_on = on.curve.points.iter().map(|p| p[3]).collect::<Vec<_>>();
    // Both errors are measured against the same noisy reference, so each may be off by
    // its noise N; the comment reports 2N/e(V⁰) for context. The row keeps the
    // tolerance it was registered with (≤ 1): an allowance added after the row missed
    // would be a band chosen after the fact (review of session 29).
    let allowance = 2.0 * noise / e_on[0];
    r.rows.push(
        Row::new(
            "image error after the last round / V⁰, importance from the eye",
            None,
            e_on[e_on.len() - 1] / e_on[0],
            "",
            Tolerance::AtMost(1.0),
        )
        .comment(format!(
            "errors per round: importance {e_on:.4?}, none {e_off:.4?}; reference noise \
             {noise:.4}, 2 × noise / V⁰ error = {allowance:.4} (context, not a band)"
        )),
    );
    let e_star = off.curve.best().max(on.curve.best());
    r.rows.push(Row::new(
        "common image error level (the larger of the two runs' best)",
        None,
        e_star,
        "",
        Tolerance::Info,
    ));
    let t_on = on.curve.at_error(e_star, 2);
    let t_off = off.curve.at_error(e_star, 2);
    // The comparison means something only where the runs' errors differ by more than
    // the reference's noise: the spread of either run's errors must exceed it.
    let spread = |e: &[f64]| {
        e.iter().fold(f64::NEG_INFINITY, |a, &b| a.max(b))
            - e.iter().fold(f64::INFINITY, |a, &b| a.min(b))
    };
    let conclusive = spread(&e_on).max(spread(&e_off)) > 2.0 * noise;
    r.rows.push(
        Row::new(
            "solve CPU time with importance / without, at equal image error (paper: < 1)",
            None,
            t_on / t_off,
            "",
            if conclusive {
                Tolerance::AtMost(1.0)
            } else {
                Tolerance::Info
            },
        )
        .comment(format!(
            "{}importance {t_on:.2} CPU s, none {t_off:.2} CPU s, same run; links {:.0} vs {:.0}",
            if conclusive {
                ""
            } else {
                "inconclusive (info): refinement changed the image error by less than twice \
                 the reference's noise; "
            },
            on.curve.at_error(e_star, 0),
            off.curve.at_error(e_star, 0)
        )),
    );

    // The three final gathers on the importance solution, at half the resolution
    // (the complete gather sends rays to every node of every patch), against the
    // reference and the direct image at the same size.
    let small = View::new(&camera, w / factor, h / factor)?;
    let t = Stopwatch::start();
    let direct_small = render_radiance(
        &GlossyField {
            solution: &on.sol,
            gather: None,
        },
        &small,
        &image_opts(),
        &|_| {},
    )?;
    let direct_secs = t.elapsed().cpu_or_wall();
    let (direct_err, _) = direct_small.reflected_relative_l1(&ref_small, &mask_small)?;
    let mut gathers = Vec::new();
    for mode in [GatherMode::All, GatherMode::Linked, GatherMode::Root] {
        let t = Stopwatch::start();
        let img = render_radiance(
            &GlossyField {
                solution: &on.sol,
                gather: Some((mode, gather_rays)),
            },
            &small,
            &image_opts(),
            &|_| {},
        )?;
        let secs = t.elapsed().cpu_or_wall();
        let (e, _) = img.reflected_relative_l1(&ref_small, &mask_small)?;
        gathers.push((mode, e, secs, img));
    }
    for (mode, e, secs, _) in &gathers {
        r.rows.push(
            Row::new(
                format!("final gather ({}): image error", mode.name()),
                None,
                *e,
                "",
                Tolerance::Info,
            )
            .comment(format!(
                "{secs:.2} CPU s, {:.1}× the direct image's {direct_secs:.3} CPU s (direct error \
                 {direct_err:.4}, same size)",
                secs / direct_secs
            )),
        );
    }
    let (_, e_all, s_all, _) = &gathers[0];
    r.rows.push(
        Row::new(
            "final gather (all) time / direct image time",
            Some(8.0),
            s_all / direct_secs,
            "",
            Tolerance::Info,
        )
        .comment("paper: ≈ 2 h gather vs 15 min direct at 600²; ours at the gathers' size above"),
    );
    r.rows.push(
        Row::new(
            "final gather (all) error / direct error (paper: < 1)",
            None,
            e_all / direct_err,
            "",
            if (direct_err - e_all).abs() > 2.0 * noise {
                Tolerance::AtMost(1.0)
            } else {
                Tolerance::Info
            },
        )
        .comment(format!(
            "direct {direct_err:.4}, gather {e_all:.4}, reference noise {noise:.4} (info \
             when the two differ by less than twice the noise)"
        )),
    );

    let mut strip = vec![
        (
            "reference.png",
            "glossy path tracer".to_string(),
            &reference,
        ),
        (
            "direct-none.png",
            "direct, importance off".into(),
            &off.image,
        ),
        (
            "direct-importance.png",
            "direct, importance on".into(),
            &on.image,
        ),
    ];
    for (mode, _, _, img) in &gathers {
        strip.push((
            match mode {
                GatherMode::All => "gather-all.png",
                GatherMode::Linked => "gather-linked.png",
                _ => "gather-root.png",
            },
            format!("final gather ({}), importance on", mode.name()),
            img,
        ));
    }
    let exposure = reference.auto_exposure();
    for (file, caption, img) in strip {
        let path = ctx.figure_path(file);
        img.write_png(&path, ToneMap::Exposure(exposure))?;
        r.figures.push(Figure { path, caption });
    }
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The teapot's fronts face out: at every patch's centre the normal points away
    /// from a point inside the body (the axis point at the same height for the knob's
    /// neck) or from the centre curve (tubes).
    #[test]
    fn teapot_patches_face_out() {
        let patches = teapot_patches();
        assert_eq!(patches.len(), 28);
        for (name, ctrl) in &patches {
            let b = BezierPatch {
                degree_u: 3,
                degree_v: 3,
                control: ctrl.iter().flatten().copied().collect(),
            };
            let (p, du, dv) = b.eval(0.5, 0.5);
            let n = du.cross(dv);
            let away = if name.contains("handle") || name.contains("spout") {
                // The centre curve's control points are the rows' end midpoints; its
                // point at u = ½ is (c₀ + 3c₁ + 3c₂ + c₃)/8.
                let c: Vec<DVec3> = ctrl.iter().map(|row| 0.5 * (row[0] + row[3])).collect();
                p - (c[0] + 3.0 * c[1] + 3.0 * c[2] + c[3]) / 8.0
            } else if name.contains("knob") {
                // The knob's neck faces down and out: away from the axis.
                p - DVec3::new(0.0, 0.0, p.z)
            } else {
                p - DVec3::new(0.0, 0.0, 1.2)
            };
            assert!(n.dot(away) > 0.0, "{name}: normal {n} vs {away}");
        }
    }

    #[test]
    fn maze_has_152_lit_sides() -> anyhow::Result<()> {
        let (scene, _) = maze_teapot()?;
        let g = GlossyScene::new(&scene, "t", WardVariant::Original, &ImportanceSource::Off)?;
        assert_eq!(g.patches.len(), 152);
        Ok(())
    }
}
