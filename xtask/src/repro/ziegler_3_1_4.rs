//! Ziegler §3.1.4 (seed 004): comparison of the Haar, multiwavelet (M2) and CDV bases by
//! projecting a 1D function with a jump (Fig. 3.5), a 2D function with a jump along
//! `3(x + y) = 4` (Fig. 3.6, compression table) and the smooth `√(xy)` (relative L1
//! error table).
//!
//! Every number of ours is computed here from `wavelux::mra`; the paper's numbers are
//! the constants below, quoted from the seed text.
//!
//! Tolerances (issue 13 §1: derived from a stated accuracy, or why not):
//! - compression shares, `±0.10` absolute: **not derived**. The thesis prints the
//!   shares to two digits (quoting precision ±0.005) but not the coefficient
//!   normalisation or the number of levels, and both move coefficients across a
//!   threshold ε; 0.10 is our judgment of that effect, not a measured bound.
//! - relative L1 errors, `±15 %`: **not derived from a stated accuracy** (the thesis
//!   does not say how it integrated `|f − Pf|`); the grid table of this report measures
//!   how much the evaluation rule moves each value (up to 17 % for MW on g between
//!   coarse and converged grids), and 15 % is a judgment inside that spread. The one
//!   band (`MW_G_BAND`, 20 %) is that measured spread, registered only while the
//!   thesis's value lies between our coarse-grid and converged values.

use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::mra::poly::shifted_legendre_all;
use wavelux::mra::project::{CellQuery, evaluate, project_moments};
use wavelux::mra::tensor::{nonstandard_decompose, standard_decompose};
use wavelux::mra::{Alpert, Cdv, Mra};
use wavelux::quadrature::GaussLegendre;

/// Ziegler §3.1.4, relative L1 error table, row "f (discontinuous)": Haar, MW, CDV.
const PAPER_L1_F: [f64; 3] = [4.42e-2, 3.04e-2, 3.00e-2];
/// Ziegler §3.1.4, relative L1 error table, row "g (smooth)": Haar, MW, CDV.
const PAPER_L1_G: [f64; 3] = [1.72e-2, 1.87e-3, 1.31e-3];
/// Ziegler §3.1.4, compression table: thresholds ε (the rows between 1e-6 and 1e-12
/// are elided in the thesis).
const PAPER_EPS: [f64; 7] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-12];
/// Ziegler §3.1.4, compression table: share of wavelet coefficients below ε, columns
/// Haar, MW_1, CDV_4.
const PAPER_SHARE: [[f64; 3]; 7] = [
    [1.00, 1.00, 0.99],
    [0.96, 0.96, 0.88],
    [0.73, 0.78, 0.71],
    [0.38, 0.68, 0.52],
    [0.24, 0.56, 0.33],
    [0.16, 0.42, 0.25],
    [0.16, 0.13, 0.09],
];
/// Location of the jump of f in (3.3) and of the line x + y = 4/3 in (3.4).
const JUMP_1D: f64 = 2.0 / 3.0;
const LINE_2D: f64 = 4.0 / 3.0;

/// (row quantity, paper value, [(grid, our value)]).
type GridValues = (String, f64, Vec<(usize, f64)>);

struct Basis {
    label: &'static str,
    mra: Box<dyn Mra>,
    /// Our (dyadic) level with 32 functions per axis.
    level: u32,
    /// Ziegler's level number for the same space.
    ziegler_level: u32,
}

fn bases() -> anyhow::Result<Vec<Basis>> {
    Ok(vec![
        Basis {
            label: "Haar",
            mra: Box::new(Alpert::haar()),
            level: 5,
            ziegler_level: 5,
        },
        Basis {
            label: "MW",
            mra: Box::new(Alpert::new(2)?),
            level: 4,
            ziegler_level: 4,
        },
        Basis {
            label: "CDV",
            mra: Box::new(Cdv::new()),
            level: 5,
            ziegler_level: 3,
        },
    ])
}

/// f of Ziegler (3.3).
fn f1(x: f64) -> f64 {
    if 3.0 * x < 2.0 {
        (std::f64::consts::PI * x).tan()
    } else {
        0.0
    }
}

/// f of Ziegler (3.4) (`disc = true`) or g = √(xy).
fn f2(x: f64, y: f64, disc: bool) -> f64 {
    if disc && 3.0 * (x + y) > 4.0 {
        0.0
    } else {
        (x * y).sqrt()
    }
}

/// Orthonormal Legendre polynomials of the level-`q` cell `c` at `x`, into `out`.
fn legendre_at(q: u32, c: usize, x: f64, out: &mut [f64]) {
    let scale = (q as f64).exp2();
    shifted_legendre_all(x * scale - c as f64, out);
    let norm = (0.5 * q as f64).exp2();
    out.iter_mut().for_each(|v| *v *= norm);
}

/// Quadrature rules used for the moments.
struct Rules {
    g10: (Vec<f64>, Vec<f64>),
    g24: (Vec<f64>, Vec<f64>),
}

impl Rules {
    fn new() -> anyhow::Result<Self> {
        Ok(Self {
            g10: GaussLegendre::new(10)?.unit(),
            g24: GaussLegendre::new(24)?.unit(),
        })
    }
}

/// `∫_{x0}^{x1} √x L_a(x) dx` for all `a` (cell `c` of level `q`), exact: with `x = s²`
/// the integrand `2 s² L_a(s²)` is a polynomial of degree ≤ 12, integrated by 10 Gauss
/// points.
fn sqrt_moments(r: &Rules, q: u32, c: usize, x0: f64, x1: f64, out: &mut [f64]) {
    out.fill(0.0);
    let (s0, s1) = (x0.sqrt(), x1.sqrt());
    let mut leg = vec![0.0; out.len()];
    for (&t, &w) in r.g10.0.iter().zip(&r.g10.1) {
        let s = s0 + (s1 - s0) * t;
        let x = s * s;
        legendre_at(q, c, x, &mut leg);
        let wt = w * (s1 - s0) * 2.0 * s * s;
        for (o, l) in out.iter_mut().zip(&leg) {
            *o += wt * l;
        }
    }
}

/// Moments `∫∫_cell f L_a(x) L_b(y)` of f (3.4) or g, row-major `(a, b)`. Cells fully
/// inside or outside the region `3(x+y) ≤ 4` use products of exact 1D moments; cells cut
/// by the line are integrated iteratively: the inner y-integral up to `min(y1, 4/3 − x)`
/// exactly (substitution `y = t²`), the outer x-integral split at the kinks
/// `x = 4/3 − y1`, `x = 4/3 − y0` with the substitution `x = s²` and 24 Gauss points on
/// a smooth integrand.
fn moments_2d(r: &Rules, q: &CellQuery<'_>, disc: bool, out: &mut [f64]) {
    let nl = q.n_legendre;
    let (x0, y0) = (q.lower(0), q.lower(1));
    let w = q.width();
    let (x1, y1) = (x0 + w, y0 + w);
    let (cx, cy) = (q.cell[0], q.cell[1]);
    out.fill(0.0);
    if disc && x0 + y0 >= LINE_2D {
        return;
    }
    let mut mx = vec![0.0; nl];
    let mut my = vec![0.0; nl];
    if !disc || x1 + y1 <= LINE_2D {
        sqrt_moments(r, q.level, cx, x0, x1, &mut mx);
        sqrt_moments(r, q.level, cy, y0, y1, &mut my);
        for a in 0..nl {
            for b in 0..nl {
                out[a * nl + b] = mx[a] * my[b];
            }
        }
        return;
    }
    let mut cuts = vec![x0, x1];
    for k in [LINE_2D - y1, LINE_2D - y0] {
        if k > x0 && k < x1 {
            cuts.push(k);
        }
    }
    cuts.sort_by(f64::total_cmp);
    let mut lx = vec![0.0; nl];
    for p in cuts.windows(2) {
        let (s0, s1) = (p[0].sqrt(), p[1].sqrt());
        for (&t, &wq) in r.g24.0.iter().zip(&r.g24.1) {
            let s = s0 + (s1 - s0) * t;
            let x = s * s;
            let u = y1.min(LINE_2D - x);
            if u <= y0 {
                continue;
            }
            sqrt_moments(r, q.level, cy, y0, u, &mut my);
            legendre_at(q.level, cx, x, &mut lx);
            let wt = wq * (s1 - s0) * 2.0 * s * s;
            for a in 0..nl {
                for b in 0..nl {
                    out[a * nl + b] += wt * lx[a] * my[b];
                }
            }
        }
    }
}

/// Moments of f (3.3) on a 1D cell: split at the jump, 32 Gauss points per piece. f is
/// not integrable at x = 1/2 (a simple pole of tan): on the two cells touching 1/2 the
/// rule returns a finite, rule-dependent value (see the report).
fn moments_1d(g32: &(Vec<f64>, Vec<f64>), q: &CellQuery<'_>, out: &mut [f64]) {
    let x0 = q.lower(0);
    let x1 = x0 + q.width();
    let mut cuts = vec![x0, x1];
    if JUMP_1D > x0 && JUMP_1D < x1 {
        cuts.insert(1, JUMP_1D);
    }
    out.fill(0.0);
    let mut leg = vec![0.0; out.len()];
    for p in cuts.windows(2) {
        for (&t, &w) in g32.0.iter().zip(&g32.1) {
            let x = p[0] + (p[1] - p[0]) * t;
            let fv = f1(x) * w * (p[1] - p[0]);
            legendre_at(q.level, q.cell[0], x, &mut leg);
            for (o, l) in out.iter_mut().zip(&leg) {
                *o += fv * l;
            }
        }
    }
}

/// Relative L1 error `∫|f − Pf| / ∫|f|` on an `n × n` midpoint grid (dyadic points, where
/// CDV point values are exact). Returns (error integral, integral of |f|).
fn l1_error(b: &Basis, coeffs: &[f64], n: usize, disc: bool) -> anyhow::Result<(f64, f64)> {
    let m = b.mra.as_ref();
    let side = m.len(b.level);
    // Per-axis tables of the non-zero scaling functions at the grid points.
    let mut table: Vec<Vec<(usize, f64)>> = Vec::with_capacity(n);
    for i in 0..n {
        let x = (i as f64 + 0.5) / n as f64;
        let mut row = Vec::new();
        for k in m.nonzero_at(b.level, x)? {
            let v = m.eval_scaling(b.level, k, x)?;
            if v != 0.0 {
                row.push((k, v));
            }
        }
        table.push(row);
    }
    let mut err = 0.0;
    let mut tot = 0.0;
    let mut r = vec![0.0; side];
    for (i, ti) in table.iter().enumerate() {
        let x = (i as f64 + 0.5) / n as f64;
        r.fill(0.0);
        for &(k, v) in ti {
            for (l, rl) in r.iter_mut().enumerate() {
                *rl += v * coeffs[k * side + l];
            }
        }
        let mut row_err = 0.0;
        let mut row_tot = 0.0;
        for (mi, tm) in table.iter().enumerate() {
            let y = (mi as f64 + 0.5) / n as f64;
            let p: f64 = tm.iter().map(|&(l, v)| v * r[l]).sum();
            let fv = f2(x, y, disc);
            row_err += (fv - p).abs();
            row_tot += fv.abs();
        }
        err += row_err;
        tot += row_tot;
    }
    let h2 = 1.0 / (n * n) as f64;
    Ok((err * h2, tot * h2))
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut report = Report {
        paper_did: "Ziegler §3.1.4 projects (a) the 1D function f(x) = tan(πx)·[3x < 2] \
(eq. 3.3, Fig. 3.5) and (b) the 2D function f(x,y) = √(xy)·[3(x+y) ≤ 4] (eq. 3.4, \
Fig. 3.6) onto spaces with n = 32 functions per axis (1024 in 2D): Haar on level 5, \
linear multiwavelets (MW) on level 4 and CDV (D4 on the interval) on level 3. It tabulates \
the share of 2D wavelet coefficients below thresholds ε = 1e-1 … 1e-12 and the relative \
L1 error of the projections of f and of the smooth g = √(xy)."
            .into(),
        ..Report::default()
    };
    let rules = Rules::new()?;
    report.param("functions per axis", 32);
    report.param("levels (ours / Ziegler)", "Haar 5/5, MW (M2) 4/4, CDV 5/3");
    let bases = bases()?;
    let samples = if ctx.quick { 512 } else { 2048 };
    fig3_5(ctx, &mut report, &bases, samples)?;
    // (b), (c) 2D: per basis the coefficients of f (3.4) and of g.
    let mut coeffs2: Vec<[Vec<f64>; 2]> = Vec::new();
    for b in &bases {
        let cf = project_moments(b.mra.as_ref(), 2, b.level, |q, out| {
            moments_2d(&rules, q, true, out)
        })?;
        let cg = project_moments(b.mra.as_ref(), 2, b.level, |q, out| {
            moments_2d(&rules, q, false, out)
        })?;
        coeffs2.push([cf, cg]);
    }
    compression(&mut report, &bases, &coeffs2)?;
    let by_grid = l1_errors(ctx, &mut report, &bases, &coeffs2)?;
    fig3_6(ctx, &mut report, &bases, &coeffs2, samples)?;
    report.we_did = we_did_text();
    register_deviations(&mut report, &by_grid);
    Ok(report)
}

/// (a) Fig. 3.5: the 1D projections of f (3.3) in every basis, `samples + 1` points.
fn fig3_5(ctx: &Ctx, report: &mut Report, bases: &[Basis], samples: usize) -> anyhow::Result<()> {
    let g32 = GaussLegendre::new(32)?.unit();
    // (a) 1D projections, Fig. 3.5.
    let mut series = Vec::new();
    let clamp = 6.0;
    let fpts: Vec<(f64, f64)> = (0..=samples)
        .map(|i| {
            let x = i as f64 / samples as f64;
            (x, f1(x).clamp(-clamp, clamp))
        })
        .collect();
    series.push(Series::new("f", fpts, Style::Line));
    for b in bases {
        let c = project_moments(b.mra.as_ref(), 1, b.level, |q, out| {
            moments_1d(&g32, q, out)
        })?;
        let mut pts = Vec::with_capacity(samples + 1);
        for i in 0..=samples {
            let x = i as f64 / samples as f64;
            let v = evaluate(b.mra.as_ref(), 1, b.level, &c, &[x])?;
            pts.push((x, v.clamp(-clamp, clamp)));
        }
        series.push(Series::new(
            format!(
                "{} (level {} in Ziegler's numbering)",
                b.label, b.ziegler_level
            ),
            pts,
            Style::Line,
        ));
    }
    let p = ctx.figure_path("fig3.5.svg");
    xy_plot(
        &p,
        "Fig. 3.5: projection of f(x) = tan(πx)·[3x<2], n = 32",
        &Axis::linear("x"),
        &Axis::linear("value (clamped to ±6)"),
        &series,
    )?;
    report.figures.push(Figure {
        path: p,
        caption: "Fig. 3.5 reproduced: f of (3.3) and its projections with 32 functions in each \
basis, evaluated at 2049 dyadic points; values clamped to ±6 because f has a pole at x = 1/2."
            .into(),
    });

    Ok(())
}

/// Compression (non-standard, as in Ziegler App. A.1, down to the coarsest level; the
/// standard decomposition for comparison): the share of wavelet coefficients of f
/// (3.4) below each ε, rows against the thesis's table.
fn compression(
    report: &mut Report,
    bases: &[Basis],
    coeffs2: &[[Vec<f64>; 2]],
) -> anyhow::Result<()> {
    let mut comp_rows = Vec::new();
    let mut comp_std_rows = Vec::new();
    let mut shares = vec![[0.0; 3]; PAPER_EPS.len()];
    for (bi, b) in bases.iter().enumerate() {
        let m = b.mra.as_ref();
        let j0 = m.min_level();
        let side = m.len(b.level);
        let n0 = m.len(j0);
        for (std_, rows) in [(false, &mut comp_rows), (true, &mut comp_std_rows)] {
            let mut w = coeffs2[bi][0].clone();
            if std_ {
                standard_decompose(m, 2, b.level, j0, &mut w)?;
            } else {
                nonstandard_decompose(m, 2, b.level, j0, &mut w)?;
            }
            let wav: Vec<f64> = w
                .iter()
                .enumerate()
                .filter(|(flat, _)| !(flat / side < n0 && flat % side < n0))
                .map(|(_, &v)| v.abs())
                .collect();
            let mut cells = vec![format!("{} ({} wavelets)", b.label, wav.len())];
            for (ei, &eps) in PAPER_EPS.iter().enumerate() {
                let share = wav.iter().filter(|&&v| v < eps).count() as f64 / wav.len() as f64;
                if !std_ {
                    shares[ei][bi] = share;
                }
                cells.push(format!("{:.1}%", 100.0 * share));
            }
            rows.push(cells);
        }
    }
    let mut headers = vec!["basis".to_string()];
    headers.extend(PAPER_EPS.iter().map(|e| format!("ε = {e:e}")));
    report.tables.push(Table {
        title: "Compression, non-standard 2D decomposition (ours): share of wavelet \
coefficients with |d| < ε"
            .into(),
        headers: headers.clone(),
        rows: comp_rows,
    });
    report.tables.push(Table {
        title: "Compression, standard 2D decomposition (ours, for comparison)".into(),
        headers,
        rows: comp_std_rows,
    });
    for (ei, &eps) in PAPER_EPS.iter().enumerate() {
        for (bi, b) in bases.iter().enumerate() {
            let row = Row::new(
                format!(
                    "share of wavelet coefficients below ε = {eps:e}, {}",
                    b.label
                ),
                Some(PAPER_SHARE[ei][bi]),
                shares[ei][bi],
                "",
                Tolerance::Absolute(0.10),
            );
            report.rows.push(row);
        }
    }

    Ok(())
}

/// Relative L1 errors of the 2D projections, with their dependence on the evaluation
/// grid (midpoint rule on n × n); returns every row's values per grid.
fn l1_errors(
    ctx: &Ctx,
    report: &mut Report,
    bases: &[Basis],
    coeffs2: &[[Vec<f64>; 2]],
) -> anyhow::Result<Vec<GridValues>> {
    let grids: Vec<usize> = if ctx.quick {
        vec![32, 64, 128, 256, 512, 1024]
    } else {
        vec![32, 64, 128, 256, 512, 1024, 2048, 4096]
    };
    let finest = *grids.last().unwrap_or(&1024);
    report.param("L1 evaluation grid (midpoints per axis)", finest);
    let mut l1_table = Vec::new();
    let mut by_grid: Vec<GridValues> = Vec::new();
    for (bi, b) in bases.iter().enumerate() {
        for (fi, disc) in [true, false].into_iter().enumerate() {
            let name = if disc {
                "f (3.4), discontinuous"
            } else {
                "g = √(xy), smooth"
            };
            let mut cells = vec![format!("{}, {}", b.label, name)];
            let mut last = f64::NAN;
            let mut vals = Vec::new();
            for &g in &grids {
                let (e, t) = l1_error(b, &coeffs2[bi][fi], g, disc)?;
                last = e / t;
                vals.push((g, last));
                cells.push(format!("{:.3e}", last));
            }
            let paper = if disc { PAPER_L1_F[bi] } else { PAPER_L1_G[bi] };
            by_grid.push((
                format!("relative L1 error, {name}, {}", b.label),
                paper,
                vals,
            ));
            cells.push(format!("{paper:.2e}"));
            l1_table.push(cells);
            report.rows.push(Row::new(
                format!("relative L1 error, {name}, {}", b.label),
                Some(paper),
                last,
                "",
                Tolerance::Relative(0.15),
            ));
        }
    }
    let mut headers = vec!["basis, function".to_string()];
    headers.extend(grids.iter().map(|g| format!("{g}²")));
    headers.push("paper".into());
    report.tables.push(Table {
        title: "Relative L1 error ∫|f − Pf| / ∫|f| by the midpoint rule on n × n grids (ours); \
the finest grid is the converged value used in the rows above"
            .into(),
        headers,
        rows: l1_table,
    });

    Ok(by_grid)
}

/// Fig. 3.6 analogue: slices (x = y and y = 0.75) of the 2D projections of f (3.4).
fn fig3_6(
    ctx: &Ctx,
    report: &mut Report,
    bases: &[Basis],
    coeffs2: &[[Vec<f64>; 2]],
    samples: usize,
) -> anyhow::Result<()> {
    for (name, title, line) in [
        (
            "fig3.6-diagonal.svg",
            "Fig. 3.6 (slice x = y): projections of f (3.4)",
            None,
        ),
        (
            "fig3.6-y075.svg",
            "Fig. 3.6 (slice y = 0.75): projections of f (3.4)",
            Some(0.75),
        ),
    ] {
        let mut series = Vec::new();
        let pos = |t: f64| -> (f64, f64) { line.map_or((t, t), |y| (t, y)) };
        series.push(Series::new(
            "f",
            (0..=samples)
                .map(|i| {
                    let t = i as f64 / samples as f64;
                    let (x, y) = pos(t);
                    (t, f2(x, y, true))
                })
                .collect(),
            Style::Line,
        ));
        for (bi, b) in bases.iter().enumerate() {
            let mut pts = Vec::new();
            for i in 0..=samples {
                let t = i as f64 / samples as f64;
                let (x, y) = pos(t);
                pts.push((
                    t,
                    evaluate(b.mra.as_ref(), 2, b.level, &coeffs2[bi][0], &[x, y])?,
                ));
            }
            series.push(Series::new(b.label, pts, Style::Line));
        }
        let p = ctx.figure_path(name);
        xy_plot(
            &p,
            title,
            &Axis::linear("x"),
            &Axis::linear("value"),
            &series,
        )?;
        report.figures.push(Figure {
            path: p,
            caption: format!(
                "{title}; 1024 functions per basis (32 per axis). Ziegler shows the 2D \
projections as images; we plot slices."
            ),
        });
    }

    Ok(())
}

/// Ziegler §3.1.4's MW error of g (1.87e-3) lies between our midpoint-rule values on
/// coarse evaluation grids, while ours is converged on the finest: the band covers the
/// 17 % by which the converged value exceeds the thesis's.
const MW_G_BAND: f64 = 0.20;

/// Registered deviations. The MW error of g gets [`MW_G_BAND`] only while the evidence
/// of its reason holds in this run: our value converged (the two finest grids within
/// 1 %) and two consecutive coarser grids bracketing the thesis's number. The CDV
/// compression shares at ε = 1e-3 … 1e-5 have no band: their deviation (ours has 10–14
/// points more small coefficients) is not explained (our projections are exact, the
/// thesis does not say how it computed its CDV coefficients) and they fail.
fn register_deviations(report: &mut Report, by_grid: &[GridValues]) {
    for row in &mut report.rows {
        if !row.quantity.starts_with("relative L1 error, g") || !row.quantity.ends_with("MW") {
            continue;
        }
        let Some((_, paper, vals)) = by_grid.iter().find(|r| r.0 == row.quantity) else {
            continue;
        };
        let n = vals.len();
        let converged =
            n >= 2 && (vals[n - 1].1 - vals[n - 2].1).abs() <= 1e-2 * vals[n - 1].1.abs();
        let bracket = vals
            .windows(2)
            .find(|w| (w[0].1 - paper) * (w[1].1 - paper) <= 0.0);
        if let (true, Some(w)) = (converged, bracket) {
            *row = row.clone().deviation(
                Tolerance::Relative(MW_G_BAND),
                format!(
                    "our value is the midpoint-rule integral converged on the finest grid (the \
two finest differ by {:.2}%); the error of g sits in the cells along the axes, where √ is \
singular, and our {}² and {}² grids give {:.3e} and {:.3e}, bracketing the thesis's {:.3e}: \
consistent with a coarse evaluation grid, which the thesis does not state",
                    100.0 * (vals[n - 1].1 / vals[n - 2].1 - 1.0).abs(),
                    w[0].0,
                    w[1].0,
                    w[0].1,
                    w[1].1,
                    paper
                ),
            );
        }
    }
}

fn we_did_text() -> String {
    "\
* **Bases and levels.** n = 32 functions per axis: Haar = `Alpert::haar()` on level 5, \
MW = `Alpert::new(2)` (linear multiwavelets, 2 functions per cell) on level 4, \
CDV = `Cdv::new()` on our dyadic level 5. Ziegler counts CDV levels from the coarsest \
space, which has 4 functions (two left and two right boundary functions), so his \
\"level 3\" has 4·2³ = 32 functions — our level 5 (2⁵ = 32). This reconciles his \
\"n = 32 … CDV level 3\" (and n = 1024 = 32² in 2D).
* **Projections** are exact L2 projections up to quadrature error ~1e-14: \
Legendre moments of f on cells (level j for Haar/MW, level j+3 with degree ≤ 5 for CDV), \
transferred exactly to the basis (`Mra::legendre_products`, exact cell moments of D4 from \
the refinement equation) and pulled down. In 2D the √ singularities are removed by the \
substitutions x = s², y = t² (making the integrands polynomial or analytic) and the \
cells cut by the line 3(x+y) = 4 are integrated iteratively with the inner upper limit \
min(y₁, 4/3 − x) and the outer integral split at its kinks, so neither the jump nor the \
singularity pollutes the comparison.
* **1D function (3.3).** tan(πx) has a simple pole at x = 1/2 inside 3x < 2, so f is not \
integrable there and the L2 projection coefficients of the functions touching x = 1/2 do \
not exist. Like any quadrature-based projection, ours (32 Gauss points per piece, the jump \
at 2/3 split exactly) returns finite, rule-dependent values there; the figure is clamped \
to ±6. Away from the pole the projections behave as in Fig. 3.5 (higher-order bases \
follow the smooth part closely, wiggles at the jump at x = 2/3).
* **Relative L1 error** = ∫|f − Pf| / ∫|f| by the midpoint rule on dyadic n × n grids \
(CDV point values are exact at dyadic points), n up to 4096 (quick: 1024); the table shows \
the convergence in n. Five of six values agree with the thesis within 15%; MW on g is 17% \
above it (a registered deviation: coarse evaluation grids bracket the thesis value).
* **Compression**: non-standard 2D decomposition (Ziegler Appendix A.1) down to the coarsest \
level (Haar and MW: level 0, CDV: level 2 = Ziegler's 0); share of the wavelet \
coefficients (all but the coarsest scaling block) with |d| < ε, orthonormal \
normalisation. The thesis does not state these conventions, but with them our Haar and MW \
columns reproduce the thesis within 1.5 percentage points at every ε. Our CDV column \
agrees at ε = 1e-1 and 1e-12 (exact zeros) but has 5–14 points more small coefficients at \
ε = 1e-2 … 1e-6; at 1e-3 … 1e-5 this is outside the ±10-point tolerance and the rows \
fail: we have not found the cause (our projections are exact; the thesis does not say how it \
computed its CDV coefficients, and errors of 1e-5 … 1e-3 in them would shift exactly these rows). The standard \
decomposition is shown for comparison."
        .into()
}
