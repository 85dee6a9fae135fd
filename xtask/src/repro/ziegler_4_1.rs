//! Ziegler §4.1 (seed 004): comparison of wavelet bases on the "Unoccluded" and
//! "Occluded" scenes — relative L1 error on the receiver S0 against the number of
//! links (Figs. 4.4, 4.5) and fractional visibility vs visibility in quadrature
//! (Fig. 4.3).
//!
//! Every number of ours is computed here with `wavelux::solver`; the paper's numbers are
//! the constants below, quoted from the seed text.
//!
//! Tolerances (issue 13 §1: derived from a stated accuracy, or why not):
//! - the ranking rows (`… / … ≥ 1` or `≤ 1`, and links Haar / links CDV ≥ 1):
//!   **derived** from what the thesis states, which is a ranking (which basis is more
//!   accurate, which needs fewer links); the tolerance is the ranking itself, with no
//!   margin. The thesis's "up to half the links" (2×) is quoted, not tested: it is an
//!   upper bound on a gain, not a stated value.
//! - Fig. 4.3's fractional / in-quadrature error ratio `≥ 1`: **derived** the same way
//!   (the thesis: fractional visibility fails at shadow boundaries).
//! - smallest MW error in the unoccluded sweep `≤ 5 %`: **not derived**: a sanity bound
//!   on our own sweep (the thesis gives no value); the report prints the measured one.

use std::fmt::Write as _;
use std::path::Path;

use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::{Ctx, write_atomic};
use wavelux::geometry::formfactor::point_to_polygon;
use wavelux::param::glam::{DVec2, DVec3};
use wavelux::scene::builtin::{ZIEGLER_EMISSION, ZIEGLER_RHO0, occluded, unoccluded};
use wavelux::scene::{Scene, Shape};
use wavelux::solver::{BasisKind, Solution, SolverConfig, Visibility, solve};

/// Ziegler §4.1.4: "acceptable solutions could be computed based on 2000 links".
const PAPER_ACCEPTABLE_LINKS: f64 = 2000.0;
/// Ziegler §4.1.4: CDV needs up to half the links of Haar for the same accuracy.
const PAPER_HAAR_OVER_CDV_LINKS: f64 = 2.0;

/// Receiver radiosity on an `n × n` midpoint grid of S0 (patch 0 of surface 0).
fn grid(sol: &Solution, n: usize) -> Vec<f64> {
    let p = sol.by_surface[0][0];
    let mut v = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let (s, t) = ((i as f64 + 0.5) / n as f64, (j as f64 + 0.5) / n as f64);
            v.push(sol.radiosity(p, s, t)[0]);
        }
    }
    v
}

fn l1(a: &[f64], reference: &[f64]) -> f64 {
    let num: f64 = a.iter().zip(reference).map(|(x, y)| (x - y).abs()).sum();
    let den: f64 = reference.iter().map(|y| y.abs()).sum();
    num / den
}

/// Exact unoccluded solution `ρ₀ E F(p → S1)` on the grid (point-to-polygon form
/// factors, Lambert's formula).
fn analytic(scene: &Scene, n: usize) -> anyhow::Result<Vec<f64>> {
    let Shape::Parallelogram {
        origin,
        edge_u,
        edge_v,
    } = scene.surfaces[1].shape
    else {
        anyhow::bail!("unoccluded emitter is not a parallelogram");
    };
    let poly = [
        origin,
        origin + edge_u,
        origin + edge_u + edge_v,
        origin + edge_v,
    ];
    // Receiver normal +z (built from the emitter's vector type; xtask has no glam).
    let mut up = origin;
    (up.x, up.y, up.z) = (0.0, 0.0, 1.0);
    let mut v = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let mut x = origin;
            (x.x, x.y, x.z) = (
                (i as f64 + 0.5) / n as f64,
                (j as f64 + 0.5) / n as f64,
                0.0,
            );
            let f = point_to_polygon(x, up, &poly)?.abs();
            v.push(ZIEGLER_RHO0 * ZIEGLER_EMISSION * f);
        }
    }
    Ok(v)
}

/// Corners of a parallelogram surface.
fn corners(scene: &Scene, surface: usize) -> anyhow::Result<[DVec3; 4]> {
    let Shape::Parallelogram {
        origin,
        edge_u,
        edge_v,
    } = scene.surfaces[surface].shape
    else {
        anyhow::bail!("surface {surface} is not a parallelogram");
    };
    Ok([
        origin,
        origin + edge_u,
        origin + edge_u + edge_v,
        origin + edge_v,
    ])
}

/// Signed area of a polygon in the xy plane.
fn signed_area(p: &[DVec2]) -> f64 {
    (0..p.len())
        .map(|i| {
            let (a, b) = (p[i], p[(i + 1) % p.len()]);
            a.x * b.y - a.y * b.x
        })
        .sum::<f64>()
        / 2.0
}

/// `subject ∩ clip` for a convex `clip` (Sutherland–Hodgman, xy plane).
fn clip_convex(subject: &[DVec2], clip: &[DVec2]) -> Vec<DVec2> {
    let orient = signed_area(clip).signum();
    let mut out = subject.to_vec();
    for i in 0..clip.len() {
        if out.is_empty() {
            break;
        }
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        let side = |p: DVec2| orient * ((b - a).perp_dot(p - a));
        let input = std::mem::take(&mut out);
        for k in 0..input.len() {
            let (p, q) = (input[k], input[(k + 1) % input.len()]);
            let (sp, sq) = (side(p), side(q));
            if sp >= 0.0 {
                out.push(p);
            }
            if (sp >= 0.0) != (sq >= 0.0) {
                out.push(p + (q - p) * (sp / (sp - sq)));
            }
        }
    }
    out
}

/// Form factor from the point `x` (normal +z) to the part of the convex polygon
/// `poly` (at height 1) that the convex blocker's shadow `shadow` does not cover:
/// `F(poly) − F(poly ∩ shadow)`, both exact (Lambert's contour formula).
fn visible_form_factor(x: DVec3, poly: &[DVec2], shadow: &[DVec2]) -> anyhow::Result<f64> {
    let lift =
        |p: &[DVec2]| -> Vec<DVec3> { p.iter().map(|q| DVec3::new(q.x, q.y, 1.0)).collect() };
    let full = point_to_polygon(x, DVec3::Z, &lift(poly))?.abs();
    let hidden = clip_convex(poly, shadow);
    let covered = if hidden.len() >= 3 && signed_area(&hidden).abs() > 1e-300 {
        point_to_polygon(x, DVec3::Z, &lift(&hidden))?.abs()
    } else {
        0.0
    };
    Ok((full - covered).max(0.0))
}

/// An independent reference on S0 of "Occluded": the direct term `ρ₀ E F_vis(p →
/// emitter)` exactly (the blocker at z = ½ casts the shadow `2b − p` onto the plane
/// z = 1, so the visible emitter is a polygon difference of exact contour form
/// factors), plus the second bounce from the upper square `ρ₀ ∫ ρ₁H₁ G V` with `ρ₁H₁ =
/// B − E` taken from `master` at the midpoints of `k × k` cells and the visible form
/// factor of each cell (exact, as above). Only the small, smooth second-bounce term
/// depends on a discretisation.
fn occluded_reference(
    scene: &Scene,
    master: &Solution,
    n: usize,
    k: usize,
) -> anyhow::Result<Vec<f64>> {
    let to2 = |c: [DVec3; 4]| c.map(|p| DVec2::new(p.x, p.y));
    let emitter = to2(corners(scene, 2)?);
    let blocker = to2(corners(scene, 3)?);
    // B − E on the upper square at cell midpoints (its surfaces 1 and 2 are
    // parallelogram supports facing −z).
    let mut upper = vec![0.0; k * k];
    for (c, v) in upper.iter_mut().enumerate() {
        let y = DVec2::new(
            ((c % k) as f64 + 0.5) / k as f64,
            ((c / k) as f64 + 0.5) / k as f64,
        );
        let mut found = None;
        for surf in [1, 2] {
            for &p in &master.by_surface[surf] {
                let wavelux::solver::SupportMap::Parallelogram {
                    origin,
                    edge_u,
                    edge_v,
                } = master.patches[p].support.map
                else {
                    anyhow::bail!("occluded: upper square support is not a parallelogram");
                };
                // Solve y = o + s·u + t·v in the plane z = 1.
                let (o, u, w) = (
                    DVec2::new(origin.x, origin.y),
                    DVec2::new(edge_u.x, edge_u.y),
                    DVec2::new(edge_v.x, edge_v.y),
                );
                let det = u.perp_dot(w);
                let d = y - o;
                let (s, t) = (d.perp_dot(w) / det, u.perp_dot(d) / det);
                if (0.0..=1.0).contains(&s) && (0.0..=1.0).contains(&t) {
                    found = Some(master.radiosity(p, s, t)[0] - master.patches[p].emission[0]);
                }
            }
        }
        *v = found.ok_or_else(|| anyhow::anyhow!("occluded: no support covers {y}"))?;
    }
    let h = 1.0 / k as f64;
    let mut out = Vec::with_capacity(n * n);
    for j in 0..n {
        for i in 0..n {
            let x = DVec3::new(
                (i as f64 + 0.5) / n as f64,
                (j as f64 + 0.5) / n as f64,
                0.0,
            );
            let shadow = blocker.map(|b| 2.0 * b - DVec2::new(x.x, x.y));
            let mut irr = ZIEGLER_EMISSION * visible_form_factor(x, &emitter, &shadow)?;
            for (c, v) in upper.iter().enumerate() {
                let (cx, cy) = ((c % k) as f64 * h, (c / k) as f64 * h);
                let cell = [
                    DVec2::new(cx, cy),
                    DVec2::new(cx + h, cy),
                    DVec2::new(cx + h, cy + h),
                    DVec2::new(cx, cy + h),
                ];
                irr += v * visible_form_factor(x, &cell, &shadow)?;
            }
            out.push(ZIEGLER_RHO0 * irr);
        }
    }
    Ok(out)
}

/// Writes a grey-scale SVG image of an `n × n` grid (row 0 at the bottom).
fn heatmap(path: &Path, title: &str, v: &[f64], n: usize, vmax: f64) -> anyhow::Result<()> {
    let px = 6;
    let size = n * px;
    let mut s = String::new();
    writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{}" height="{}" shape-rendering="crispEdges">"#,
        size,
        size + 24
    )?;
    writeln!(
        s,
        r#"<text x="4" y="16" font-family="sans-serif" font-size="13">{title}</text>"#
    )?;
    for j in 0..n {
        for i in 0..n {
            let g = (255.0 * (v[j * n + i] / vmax).clamp(0.0, 1.0).powf(1.0 / 2.2)).round() as u8;
            writeln!(
                s,
                r#"<rect x="{}" y="{}" width="{px}" height="{px}" fill="rgb({g},{g},{g})"/>"#,
                i * px,
                24 + (n - 1 - j) * px
            )?;
        }
    }
    s.push_str("</svg>\n");
    write_atomic(path, s.as_bytes())
}

struct Sweep {
    label: String,
    /// (links in Ziegler's count, relative L1 error, stored link blocks) per ε.
    points: Vec<(f64, f64, usize)>,
    /// The solution on the L1 grid per ε.
    grids: Vec<Vec<f64>>,
}

impl Sweep {
    /// The same sweep measured against another reference.
    fn against(&self, reference: &[f64]) -> Sweep {
        Sweep {
            label: self.label.clone(),
            points: self
                .points
                .iter()
                .zip(&self.grids)
                .map(|(p, g)| (p.0, l1(g, reference), p.2))
                .collect(),
            grids: self.grids.clone(),
        }
    }
}

fn sweep(
    scene: &Scene,
    basis: BasisKind,
    level: u8,
    eps: &[f64],
    reference: &[f64],
    n: usize,
) -> anyhow::Result<Sweep> {
    let mut points = Vec::new();
    let mut grids = Vec::new();
    for &e in eps {
        let cfg = SolverConfig {
            basis,
            eps: e,
            max_level: level,
            quad_points: 3,
            ..SolverConfig::default()
        };
        let sol = solve(scene, &cfg)?;
        let g = grid(&sol, n);
        let err = l1(&g, reference);
        points.push((sol.stats.nonstandard_links as f64, err, sol.stats.links));
        grids.push(g);
    }
    Ok(Sweep {
        label: format!("{} (m = {level})", basis.name()),
        points,
        grids,
    })
}

/// The error of a sweep at `links` (log-log interpolation; clamped at the ends).
fn error_at(s: &Sweep, links: f64) -> f64 {
    let mut pts: Vec<(f64, f64)> = s.points.iter().map(|p| (p.0, p.1)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    if links <= pts[0].0 {
        return pts[0].1;
    }
    for w in pts.windows(2) {
        if links <= w[1].0 {
            let t = (links.ln() - w[0].0.ln()) / (w[1].0.ln() - w[0].0.ln());
            return (w[0].1.ln() + t * (w[1].1.ln() - w[0].1.ln())).exp();
        }
    }
    pts[pts.len() - 1].1
}

/// The smallest number of links at which a sweep reaches `err` (log-log interpolation
/// between the first point at or below `err` and its predecessor); `None` if never.
fn links_for(s: &Sweep, err: f64) -> Option<f64> {
    let mut pts: Vec<(f64, f64)> = s.points.iter().map(|p| (p.0, p.1)).collect();
    pts.sort_by(|a, b| a.0.total_cmp(&b.0));
    let i = pts.iter().position(|p| p.1 <= err)?;
    if i == 0 {
        return Some(pts[0].0);
    }
    let (a, b) = (pts[i - 1], pts[i]);
    let t = (err.ln() - a.1.ln()) / (b.1.ln() - a.1.ln());
    Some((a.0.ln() + t * (b.0.ln() - a.0.ln())).exp())
}

/// The run's sizes: the thesis's levels, smaller grids and fewer ε in quick mode.
struct Settings {
    n_grid: usize,
    haar_m: u8,
    mw_m: u8,
    cdv_m: u8,
    master_m: u8,
    k_cells: usize,
    eps_list: Vec<f64>,
    quick: bool,
}

impl Settings {
    fn new(quick: bool) -> Self {
        // Quick mode keeps the thesis's levels on the cheap Unoccluded scene (so its rows
        // mean the same) and lowers the Occluded master's level.
        let (haar_m, mw_m, master_m): (u8, u8, u8) = if quick { (5, 4, 4) } else { (5, 4, 5) };
        Settings {
            n_grid: if quick { 64 } else { 128 },
            haar_m,
            mw_m,
            // CDV: `max_level` is the dyadic level, 4^m functions as for Haar (Ziegler's
            // m = 3 above the coarsest CDV level 2 gives n_3 = 1024).
            cdv_m: haar_m,
            master_m,
            k_cells: if quick { 16 } else { 32 },
            eps_list: if quick {
                vec![1e-1, 3e-2, 1e-2, 3e-3, 1e-3]
            } else {
                vec![3e-1, 1e-1, 3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5]
            },
            quick,
        }
    }

    fn record(&self, report: &mut Report) {
        report.param("L1 grid on S0 (midpoints per axis)", self.n_grid);
        report.param(
            "levels Haar / MW (M2) / CDV (dyadic)",
            format!("{} / {} / {}", self.haar_m, self.mw_m, self.cdv_m),
        );
        report.param("ε sweep", format!("{:?}", self.eps_list));
        report.param("n_samp", 3);
        report.param(
            "occluded master",
            format!("M2, ε = 1e-4, level {}", self.master_m),
        );
        report.param(
            "occluded reference",
            format!(
                "exact direct term (visible-emitter contour form factors) + second bounce from \
                 the master on {}² cells",
                self.k_cells
            ),
        );
    }

    /// The ε sweeps of Haar, MW (M2) and CDV on `scene` against `reference`.
    fn sweeps(&self, scene: &Scene, reference: &[f64]) -> anyhow::Result<Vec<Sweep>> {
        let n = self.n_grid;
        Ok(vec![
            sweep(
                scene,
                BasisKind::Haar,
                self.haar_m,
                &self.eps_list,
                reference,
                n,
            )?,
            sweep(
                scene,
                BasisKind::Multiwavelet(2),
                self.mw_m,
                &self.eps_list,
                reference,
                n,
            )?,
            sweep(
                scene,
                BasisKind::Cdv,
                self.cdv_m,
                &self.eps_list,
                reference,
                n,
            )?,
        ])
    }
}

/// "Occluded": the scene, its M2 master, the independent reference and the sweeps
/// measured against both.
struct Occluded {
    scene: Scene,
    reference: Vec<f64>,
    /// Relative L1 error of the master against the independent reference.
    master_err: f64,
    /// Sweeps against the independent reference.
    sweeps: Vec<Sweep>,
    /// The same sweeps against the master (the thesis's method).
    sweeps_master: Vec<Sweep>,
}

fn occluded_runs(s: &Settings) -> anyhow::Result<Occluded> {
    let scene = occluded();
    let master_cfg = SolverConfig {
        basis: BasisKind::Multiwavelet(2),
        eps: 1e-4,
        max_level: s.master_m,
        quad_points: 3,
        ..SolverConfig::default()
    };
    let master = solve(&scene, &master_cfg)?;
    let oc_master = grid(&master, s.n_grid);
    // The independent reference: exact direct term, second bounce from the master.
    let reference = occluded_reference(&scene, &master, s.n_grid, s.k_cells)?;
    let sweeps_master = s.sweeps(&scene, &oc_master)?;
    let sweeps = sweeps_master
        .iter()
        .map(|w| w.against(&reference))
        .collect();
    Ok(Occluded {
        master_err: l1(&oc_master, &reference),
        scene,
        reference,
        sweeps,
        sweeps_master,
    })
}

/// The ε-sweep table and Figs. 4.4/4.5.
fn sweep_table_and_figures(
    ctx: &Ctx,
    report: &mut Report,
    s: &Settings,
    un_sweeps: &[Sweep],
    oc_sweeps: &[Sweep],
) -> anyhow::Result<()> {
    let (eps_list, n_grid) = (&s.eps_list, s.n_grid);
    let mut tab = Vec::new();
    for (scene, sweeps) in [("Unoccluded", un_sweeps), ("Occluded", oc_sweeps)] {
        for s in sweeps.iter() {
            for (e, p) in eps_list.iter().zip(&s.points) {
                tab.push(vec![
                    scene.to_string(),
                    s.label.clone(),
                    format!("{e:e}"),
                    format!("{}", p.0),
                    format!("{}", p.2),
                    format!("{:.3e}", p.1),
                ]);
            }
        }
    }
    for (fig, scene, sweeps) in [(4, "Unoccluded", un_sweeps), (5, "Occluded", oc_sweeps)] {
        let p = ctx.figure_path(&format!("fig4.{fig}.svg"));
        let series: Vec<Series> = sweeps
            .iter()
            .map(|s| {
                Series::new(
                    s.label.clone(),
                    s.points.iter().map(|p| (p.0, p.1)).collect(),
                    Style::LinePoints,
                )
            })
            .collect();
        xy_plot(
            &p,
            &format!("Fig. 4.{fig}: \"{scene}\", relative L1 error on S0"),
            &Axis::log("links (Ziegler's count)"),
            &Axis::log("relative L1 error"),
            &series,
        )?;
        report.figures.push(Figure {
            path: p,
            caption: format!(
                "Fig. 4.{fig} reproduced: relative L1 error on S0 ({n_grid}² midpoints) \
against the number of links, one point per ε of the sweep (Ziegler instead discarded the \
smallest coefficients of one fine solution). CDV counts one link per vertex pair \
(256 unrefined root pairs per patch pair at the coarsest CDV level)."
            ),
        });
    }

    report.tables.push(Table {
        title: "ε sweeps".into(),
        headers: [
            "scene",
            "basis",
            "ε",
            "links (Ziegler's count)",
            "stored link blocks",
            "relative L1 error",
        ]
        .map(String::from)
        .to_vec(),
        rows: tab,
    });
    Ok(())
}

/// Rows of "Unoccluded": the ranking at 2000 links and links for equal accuracy.
fn unoccluded_rows(report: &mut Report, un_sweeps: &[Sweep]) {
    let haar_un = error_at(&un_sweeps[0], PAPER_ACCEPTABLE_LINKS);
    let mw_un = error_at(&un_sweeps[1], PAPER_ACCEPTABLE_LINKS);
    report.rows.push(Row::new(
        "Unoccluded: MW relative L1 error at 2000 links",
        None,
        mw_un,
        "",
        Tolerance::Info,
    ));
    report.rows.push(Row::new(
        "Unoccluded: Haar error / MW error at 2000 links (thesis: MW best)",
        None,
        haar_un / mw_un,
        "",
        Tolerance::AtLeast(1.0),
    ));
    let cdv_un = error_at(&un_sweeps[2], PAPER_ACCEPTABLE_LINKS);
    report.rows.push(Row::new(
        "Unoccluded: CDV relative L1 error at 2000 links",
        None,
        cdv_un,
        "",
        Tolerance::Info,
    ));
    report.rows.push(Row::new(
        "Unoccluded: Haar error / CDV error at 2000 links (thesis: CDV better than Haar)",
        None,
        haar_un / cdv_un,
        "",
        Tolerance::AtLeast(1.0),
    ));
    report.rows.push(Row::new(
        "Unoccluded: CDV error / MW error at 2000 links (thesis: MW best, CDV second)",
        None,
        cdv_un / mw_un,
        "",
        Tolerance::AtLeast(1.0),
    ));
    // Links for the same accuracy: the smallest error both Haar and CDV reach.
    let floor = |s: &Sweep| s.points.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    let target = 1.05 * floor(&un_sweeps[0]).max(floor(&un_sweeps[2]));
    let (lh, lc) = (
        links_for(&un_sweeps[0], target).unwrap_or(f64::NAN),
        links_for(&un_sweeps[2], target).unwrap_or(f64::NAN),
    );
    report.rows.push(
        Row::new(
            format!(
                "Unoccluded: links Haar / links CDV for relative L1 error {target:.3e} \
(thesis: CDV needs up to half the links of Haar)"
            ),
            Some(PAPER_HAAR_OVER_CDV_LINKS),
            lh / lc,
            "",
            Tolerance::AtLeast(1.0),
        )
        .comment(format!(
            "Haar {lh:.0} links, CDV {lc:.0} links (log-log interpolation in the ε sweeps); \
passes when CDV needs fewer links than Haar."
        )),
    );
    // And at the error Haar reaches with 2000 links (mid-range, away from Haar's floor).
    let lc2 = links_for(&un_sweeps[2], haar_un).unwrap_or(f64::NAN);
    let lh2 = links_for(&un_sweeps[0], haar_un).unwrap_or(f64::NAN);
    report.rows.push(
        Row::new(
            format!(
                "Unoccluded: links Haar / links CDV for relative L1 error {haar_un:.3e} \
(Haar's error at 2000 links)"
            ),
            Some(PAPER_HAAR_OVER_CDV_LINKS),
            lh2 / lc2,
            "",
            Tolerance::AtLeast(1.0),
        )
        .comment(format!("Haar {lh2:.0} links, CDV {lc2:.0} links.")),
    );
    let best_mw_un = un_sweeps[1]
        .points
        .iter()
        .map(|p| p.1)
        .fold(f64::INFINITY, f64::min);
    report.rows.push(Row::new(
        "Unoccluded: smallest MW error in the sweep",
        None,
        best_mw_un,
        "",
        Tolerance::AtMost(0.05),
    ));
}

/// Rows of "Occluded": the ranking against the independent reference, and against the
/// master as context.
fn occluded_rows(report: &mut Report, oc: &Occluded) {
    let (oc_sweeps, oc_sweeps_master, master_err) = (&oc.sweeps, &oc.sweeps_master, oc.master_err);
    let many = oc_sweeps
        .iter()
        .map(|s| s.points.iter().map(|p| p.0).fold(0.0, f64::max))
        .fold(f64::INFINITY, f64::min);
    let haar_oc = error_at(&oc_sweeps[0], many);
    let mw_oc = error_at(&oc_sweeps[1], many);
    let cdv_oc = error_at(&oc_sweeps[2], many);
    report.rows.push(
        Row::new(
            "Occluded: relative L1 error of the M2 master against the independent reference",
            None,
            master_err,
            "",
            Tolerance::Info,
        )
        .comment(
            "the reference's direct term is exact; an error here is the master's own \
             (the thesis measured every basis against such a master)",
        ),
    );
    report.rows.push(Row::new(
        format!("Occluded: CDV error / Haar error at {many} links (thesis: CDV best)"),
        None,
        cdv_oc / haar_oc,
        "",
        Tolerance::AtMost(1.0),
    ));
    report.rows.push(Row::new(
        format!("Occluded: CDV error / MW error at {many} links (thesis: CDV best)"),
        None,
        cdv_oc / mw_oc,
        "",
        Tolerance::AtMost(1.0),
    ));
    report.rows.push(Row::new(
        format!("Occluded: MW error / Haar error at {many} links (thesis: MW worst)"),
        None,
        mw_oc / haar_oc,
        "",
        Tolerance::AtLeast(1.0),
    ));
    // The same ratios measured against the M2 master, as the thesis measured them.
    let at_master = |i: usize| error_at(&oc_sweeps_master[i], many);
    for (what, v) in [
        ("CDV error / Haar error", at_master(2) / at_master(0)),
        ("CDV error / MW error", at_master(2) / at_master(1)),
        ("MW error / Haar error", at_master(1) / at_master(0)),
    ] {
        report.rows.push(
            Row::new(
                format!(
                    "Occluded, against the M2 master (the thesis's method): {what} at {many} links"
                ),
                None,
                v,
                "",
                Tolerance::Info,
            )
            .comment("context: how the reference choice moves the ranking"),
        );
    }
}

/// Fig. 4.3 (fractional visibility against visibility in quadrature) and the
/// reference images.
fn visibility_figures(
    ctx: &Ctx,
    report: &mut Report,
    s: &Settings,
    oc: &Occluded,
    un_ref: &[f64],
) -> anyhow::Result<()> {
    let (quick, n_grid, master_m) = (s.quick, s.n_grid, s.master_m);
    let (oc_ref, master_err) = (&oc.reference, oc.master_err);
    // Fig. 4.3: fractional visibility vs visibility in quadrature, MW with 1024
    // functions (level 4; quick: level 3).
    let f_level = if quick { 3 } else { 4 };
    let mut imgs = Vec::new();
    for (name, vis) in [
        ("visibility in quadrature", Visibility::InQuadrature),
        ("fractional visibility", Visibility::Fractional),
    ] {
        let cfg = SolverConfig {
            basis: BasisKind::Multiwavelet(2),
            eps: 1e-4,
            max_level: f_level,
            visibility: vis,
            quad_points: 3,
            ..SolverConfig::default()
        };
        let sol = solve(&oc.scene, &cfg)?;
        let g = grid(&sol, n_grid);
        imgs.push((name, l1(&g, oc_ref), g, sol.stats.links));
    }
    let vmax = oc_ref.iter().fold(0.0f64, |a, &b| a.max(b));
    let p = ctx.figure_path("fig4.3-master.svg");
    heatmap(
        &p,
        "Occluded: independent reference on S0",
        oc_ref,
        n_grid,
        vmax,
    )?;
    report.figures.push(Figure {
        path: p,
        caption: format!(
            "Occluded reference on S0: exact direct term plus the second bounce of the M2 \
             master (ε = 1e-4, level {master_m}); the master itself is {master_err:.2e} away \
             in relative L1."
        ),
    });
    for (i, (name, err, g, links)) in imgs.iter().enumerate() {
        let p = ctx.figure_path(&format!("fig4.3-{}.svg", ["quadrature", "fractional"][i]));
        heatmap(
            &p,
            &format!("Occluded, MW level {f_level}: {name}"),
            g,
            n_grid,
            vmax,
        )?;
        report.figures.push(Figure {
            path: p,
            caption: format!(
                "Fig. 4.3 reproduced: S0 with {name} ({links} link blocks), relative L1 error \
{err:.3e} against the independent reference."
            ),
        });
    }
    report.rows.push(Row::new(
        "Fig. 4.3: L1 error fractional / in-quadrature visibility (thesis: fractional fails at shadows)",
        None,
        imgs[1].1 / imgs[0].1,
        "",
        Tolerance::AtLeast(1.0),
    ));
    let p = ctx.figure_path("analytic-unoccluded.svg");
    let umax = un_ref.iter().fold(0.0f64, |a, &b| a.max(b));
    heatmap(
        &p,
        "Unoccluded: analytic solution on S0",
        un_ref,
        n_grid,
        umax,
    )?;
    report.figures.push(Figure {
        path: p,
        caption: "Unoccluded analytic solution ρ₀ E F(p → S1) on S0.".into(),
    });
    Ok(())
}

fn we_did_text(s: &Settings) -> String {
    let (n_grid, master_m, k_cells) = (s.n_grid, s.master_m, s.k_cells);
    format!(
        "Scenes from `wavelux::scene::builtin::{{unoccluded, occluded}}` (the thesis's figures \
are lost; emitter of side 0.25 at height 0.1 rotated 30°, emitting part [0.25,0.75]² of the \
upper square, blocker of side 0.4 at z = 0.5 rotated 30°; all documented there). Radiosity \
on S0 is sampled at {n_grid}² cell midpoints; the unoccluded reference is ρ₀ E F(p → S1) with \
exact point-to-polygon form factors (`wavelux::geometry::formfactor`). The occluded \
reference is independent of every basis where it matters: its direct term ρ₀ E F_vis(p → \
emitter) is exact (the blocker at z = ½ casts the shadow 2b − p onto the emitter's plane, \
so the visible emitter is the emitter minus a convex polygon, and both form factors are \
Lambert's contour integrals), and only the second bounce from the upper square, ρ₀ ∫ \
(B − E) G V, uses a master M2 solution (ε = 1e-4, level {master_m}, n_samp = 3) at the \
midpoints of {k_cells}² cells with each cell's exact visible form factor. The thesis measured every \
basis against an MW master instead; the report gives the ratios both ways. Instead of discarding \
coefficients of one fine solution we sweep ε and count links the way Ziegler does (cell \
pairs whose wavelet form factors were computed: refined links plus unrefined root links). \
Oracle: kernel samples at interval midpoints (Haar: 2 per axis, MW: 3 per axis), maximum \
over axes of the mean deviation, times √(|R||E|); for CDV over the square that covers \
both vertex supports (3 cells of the level per axis). CDV (`wavelux_solver::cdv`): vertex \
links between equal-level CDV-D4 functions (boundary functions included), refinement \
deduplicated over the overlapping children, transfer coefficients from the exact \
projection of the CDV functions onto piecewise quadratics (M3) on the level's cells and \
the M3 cell-pair blocks (n_samp = 3 Gauss points per axis and cell, visibility in \
quadrature) instead of Ziegler's 3-sample piecewise-linear kernel interpolation with \
tabulated moments. The occluded scene's upper square is split into four rectangles \
around the emitting square (one support each)."
    )
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut report = Report {
        paper_did: "Ziegler §4.1 compares Haar (ε = 1e-5, m = 5), linear multiwavelets MW \
(ε = 1e-4, m = 4) and CDV (ε = 1e-4, m = 3), each with 1024 functions on the receiver, \
n_samp = 3, on \"Unoccluded\" (the Gortler et al. 1993 scene: a small rotated emitter \
close to the receiver, E = 100, ρ₀ = 0.4; reference from the analytic point-to-polygon \
form factor) and \"Occluded\" (emitting part of a parallel square, rotated blocker; \
reference a master MW solution with ε = 1e-4, m = 5). Figs. 4.4/4.5 plot the relative L1 \
error on S0 against the number of links (curves made by discarding the smallest \
coefficients). Findings: acceptable unoccluded solutions with about 2000 links \
(< 32 000 form factors, ≈ 3% of the 1024² full matrix); unoccluded ranking MW < CDV < \
Haar (error); occluded: MW worst, CDV best, Haar almost as good as CDV at many links; \
fractional visibility fails at shadow boundaries (Fig. 4.3)."
            .into(),
        ..Report::default()
    };
    let s = Settings::new(ctx.quick);
    s.record(&mut report);
    let un = unoccluded();
    let un_ref = analytic(&un, s.n_grid)?;
    let un_sweeps = s.sweeps(&un, &un_ref)?;
    let oc = occluded_runs(&s)?;
    sweep_table_and_figures(ctx, &mut report, &s, &un_sweeps, &oc.sweeps)?;
    unoccluded_rows(&mut report, &un_sweeps);
    occluded_rows(&mut report, &oc);
    visibility_figures(ctx, &mut report, &s, &oc, &un_ref)?;
    report.we_did = we_did_text(&s);
    Ok(report)
}
