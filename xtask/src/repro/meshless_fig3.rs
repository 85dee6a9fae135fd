//! Meshless §2.2, Fig. 3: the hierarchical meshless approximation `F_0 … F_L` of an
//! irradiance function refines level by level towards the function; the differences
//! `f̃_l` encoded by each level shrink.
//!
//! The paper shows images of `F_0, F_2, F_4, F_5` and `f̃_0, f̃_2, f̃_4` of the total
//! (direct plus indirect) irradiance of a scene against its path-traced reference; it
//! quotes no number.

use super::meshless_common::{scene, view_grid};
use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::meshless::relight::default_viewpoint;
use wavelux::meshless::{
    Basis, DirectLighting, MeshlessConfig, SceneSurfaces, SurfaceQuery, place_points,
};
use wavelux::render::ToneMap;

/// Problem sizes of one mode.
struct Sizes {
    scene: &'static str,
    levels: usize,
    r_coarse: f64,
    points: usize,
}

const QUICK: Sizes = Sizes {
    scene: "atrium-s",
    levels: 4,
    r_coarse: 4.0,
    points: 1500,
};

const FULL: Sizes = Sizes {
    scene: "atrium",
    levels: 6,
    r_coarse: 4.0,
    points: 8000,
};

/// Relative L1 of `a` against `b` over all channels.
fn rel_l1(a: &[[f64; 3]], b: &[[f64; 3]]) -> f64 {
    let (mut d, mut n) = (0.0, 0.0);
    for (x, y) in a.iter().zip(b) {
        for c in 0..3 {
            d += (x[c] - y[c]).abs();
            n += y[c].abs();
        }
    }
    d / n
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let s = if ctx.quick { &QUICK } else { &FULL };
    let mut r = Report::default();
    let sc = scene(s.scene)?;
    let query = SceneSurfaces::new(&sc)?;
    let cfg = MeshlessConfig {
        receiver_levels: s.levels,
        sender_levels: 1,
        r_coarse: Some(s.r_coarse),
        ..MeshlessConfig::default()
    };
    let (lo, hi) = query.bounds();
    let placement = place_points(
        &query,
        &cfg,
        default_viewpoint(&sc, (lo, hi)),
        (hi - lo).length(),
        &|_, _| {},
    )?;
    let basis = Basis::from_levels(&placement.levels, &placement.radii, 1)?;
    let lighting = DirectLighting::Lights(sc.lights.clone());
    let pts: Vec<_> = (0..basis.len())
        .map(|i| (basis.position(i), basis.normal(i)))
        .collect();
    let f: Vec<f64> = lighting
        .irradiance(&query, &pts)?
        .into_iter()
        .flatten()
        .collect();
    let alpha = basis.project(&f, 3)?;
    let grid = view_grid(&sc, &query, s.points)?;
    let exact = lighting.irradiance(&query, &grid.points)?;

    r.param(
        "scene",
        format!("builtin:{} lit by its spot (direct irradiance)", s.scene),
    );
    r.param(
        "basis",
        format!(
            "{} levels, R_coarse = {} m, points per level {:?}",
            s.levels,
            s.r_coarse,
            (0..basis.levels())
                .map(|l| basis.level_range(l).len())
                .collect::<Vec<_>>()
        ),
    );
    r.param(
        "test points",
        format!(
            "{} camera points (exact values by shadow rays)",
            grid.points.len()
        ),
    );
    r.paper_did = "Fig. 3 shows the coarse-to-fine approximation (eq. (7)) of a scene's \
        incident irradiance (direct plus indirect): F_0, F_2, F_4, F_5 approach the \
        path-traced function, and the differences f̃_0, f̃_2, f̃_4 encoded by the levels \
        shrink. No number is given."
        .into();
    r.we_did = "The function is the direct irradiance of the atrium's spot (exact by shadow \
        rays at every basis point and every camera point; ours: deterministic, and the \
        sharpest part of the paper's total irradiance, with the cone edge and the \
        arcade shadows, where the indirect part is smooth). P (eq. (7)) gives the \
        coefficients from the samples at the points; F_l sums levels 0..=l (eq. (6)), \
        f̃_l is level l alone. Errors are relative L1 of F_l against the exact function \
        at the camera points; images show F_l and f̃_l on the camera grid (f̃: red \
        positive, blue negative)."
        .into();

    let mut errs = Vec::new();
    let mut table = Vec::new();
    for l in 0..basis.levels() {
        let eval = |levels: std::ops::Range<usize>| -> Vec<[f64; 3]> {
            let mut out = [0.0; 3];
            let mut tmp = Vec::new();
            grid.points
                .iter()
                .map(|&(x, n)| {
                    basis.evaluate(&alpha, 3, levels.clone(), x, n, &mut out, &mut tmp);
                    out
                })
                .collect()
        };
        let fl = eval(0..l + 1);
        let dl = eval(l..l + 1);
        let e = rel_l1(&fl, &exact);
        let d_mag: f64 = dl.iter().flatten().map(|v| v.abs()).sum::<f64>()
            / exact.iter().flatten().map(|v| v.abs()).sum::<f64>();
        errs.push(e);
        table.push(vec![
            l.to_string(),
            basis.level_range(l).len().to_string(),
            format!("{:.2} %", 100.0 * e),
            format!("{:.2} %", 100.0 * d_mag),
        ]);
        let path = ctx.figure_path(&format!("F{l}.png"));
        grid.image(&fl).write_png(&path, ToneMap::Auto)?;
        r.figures.push(Figure {
            path,
            caption: format!("F_{l}: levels 0..={l}, relative L1 {:.2} %", 100.0 * e),
        });
        let signed: Vec<[f64; 3]> = dl
            .iter()
            .map(|v| {
                let m = (v[0] + v[1] + v[2]) / 3.0;
                [m.max(0.0), 0.0, (-m).max(0.0)]
            })
            .collect();
        let path = ctx.figure_path(&format!("f{l}.png"));
        grid.image(&signed).write_png(&path, ToneMap::Auto)?;
        r.figures.push(Figure {
            path,
            caption: format!("f̃_{l}: level {l} alone (red +, blue −)"),
        });
    }
    let path = ctx.figure_path("exact.png");
    grid.image(&exact).write_png(&path, ToneMap::Auto)?;
    r.figures.push(Figure {
        path,
        caption: "The exact function (direct irradiance) at the camera points".into(),
    });
    for l in 1..errs.len() {
        r.rows.push(
            Row::new(
                format!("error of F_{l} / error of F_{}", l - 1),
                None,
                errs[l] / errs[l - 1],
                "",
                Tolerance::AtMost(1.0),
            )
            .comment(format!(
                "F_{}: {:.2} %, F_{l}: {:.2} %",
                l - 1,
                100.0 * errs[l - 1],
                100.0 * errs[l]
            )),
        );
    }
    r.rows.push(Row::new(
        format!("relative L1 of F_{} (finest)", errs.len() - 1),
        None,
        errs[errs.len() - 1],
        "",
        Tolerance::Info,
    ));
    r.tables.push(Table {
        title: "Error of F_l and size of f̃_l (relative to the function's L1)".into(),
        headers: ["level l", "points", "error of F_l", "|f̃_l|"]
            .iter()
            .map(|h| h.to_string())
            .collect(),
        rows: table,
    });
    let path = ctx.figure_path("error-per-level.svg");
    xy_plot(
        &path,
        "Error of F_l against the function",
        &Axis::linear("level l"),
        &Axis::log("relative L1"),
        &[Series::new(
            "F_l",
            errs.iter()
                .enumerate()
                .map(|(l, &e)| (l as f64, e))
                .collect(),
            Style::LinePoints,
        )],
    )?;
    r.figures.push(Figure {
        path,
        caption: "Relative L1 of F_l per level".into(),
    });
    Ok(r)
}
