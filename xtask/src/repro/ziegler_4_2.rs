//! Ziegler §4.2 (seed 004): Picard vs GMRES vs CGNR on the box scenes with and without
//! the inner cube at high (ρ_avg 0.52) and low (0.35) reflectance (Figs. 4.12–4.15),
//! Haar, ε = 1e-4, m = 5, n_samp = 3.
//!
//! Every number of ours is computed here with `wavelux::solver`; the paper's numbers are
//! the constants below, quoted from the seed text.
//!
//! Tolerances (issue 13 §1: derived from a stated accuracy, or why not):
//! - Picard / GMRES error after three iterations, factor 3: **not derived**. The thesis
//!   says "≈ 1/25", "≈ 1/9", "≈ 1/5" (one significant digit, read from its plots);
//!   the error after k iterations goes as `q^k`, so a factor 3 on the ratio is a
//!   factor `3^{1/3} ≈ 1.44` on the per-iteration factor `q`, which our reconstructed
//!   scenes' reflectances and meshes can move; a judgment, not a bound.
//! - Picard iterations matching three GMRES iterations: "more than 8" is **derived**
//!   (the thesis's bound, `≥ 8`); "5–6" is checked as `5.5 ± 1.5`, i.e. the quoted
//!   range widened by one iteration for the reconstruction: **not derived**.
//! - `min_k` CGNR / Picard `≥ 1`: **derived** from the thesis's statement (CGNR never
//!   beats Picard), no margin.

use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::linear::{
    IdentityMinus, Operator, SolverOptions, Unsupported, cgnr as cgnr_solve, picard as picard_solve,
};
use wavelux::scene::builtin::{BoxVariant, Reflectivity, ziegler_box};
use wavelux::solver::{
    BasisKind, Hierarchy, LinearMethod, Oracle, Prepared, SolverConfig, System, hierarchy,
    solve_channel,
};

/// Ziegler §4.2.3: error of Picard / error of GMRES after three iterations, scenes in
/// the order (no cube, high), (no cube, low), (cube, high), (cube, low). The thesis
/// says "≈ 1/25 … in the unoccluded cases, ≈ 1/9 and ≈ 1/5 for the occluded scenes"
/// (we read 1/9 as the high- and 1/5 as the low-reflectance occluded scene).
const PAPER_RATIO_3: [f64; 4] = [25.0, 25.0, 9.0, 5.0];
/// Ziegler §4.2 (Figs. 4.12–4.15 as summarised in the task statement): Picard
/// iterations needed to match three GMRES iterations: more than 8 at high reflectance,
/// 5–6 at low.
/// ("more than 8" is checked as a lower bound, "5–6" as 5.5 ± 1.5).
const PAPER_PICARD_EQUIV: [f64; 4] = [8.0, 5.5, 8.0, 5.5];
/// Ziegler §4.2.2 table: computed links (no cube high, low; cube high, low).
const PAPER_LINKS: [f64; 4] = [484_452.0, 283_272.0, 898_016.0, 606_398.0];
/// Ziegler §4.2.2 table: potential links (no cube, cube).
const PAPER_POTENTIAL: [f64; 2] = [2_516_580.0, 10_066_320.0];

/// Our threshold. Ziegler's is 1e-4 in his (unstated) normalisation of the estimate;
/// with ours (smoothness of ρ·G·V times √(|R||E|)) ε = 1e-4 refines almost every pair
/// to level 5 (≈ 10⁷ links), so we use the threshold that gives link counts of the
/// thesis's order (measured: ~10⁵ non-standard links at m = 5).
const OUR_EPS: f64 = 3e-4;

struct Case {
    label: &'static str,
    cube: bool,
    refl: Reflectivity,
}

const CASES: [Case; 4] = [
    Case {
        label: "no cube, high ρ",
        cube: false,
        refl: Reflectivity::High,
    },
    Case {
        label: "no cube, low ρ",
        cube: false,
        refl: Reflectivity::Low,
    },
    Case {
        label: "cube, high ρ",
        cube: true,
        refl: Reflectivity::High,
    },
    Case {
        label: "cube, low ρ",
        cube: true,
        refl: Reflectivity::Low,
    },
];

/// `K` with its own application standing in for the transpose: the operator a CGNR
/// sees when `Kᵀ` is taken to be `K` (links assumed symmetric, the reflectance applied
/// on the receiving side in both directions). Used to test whether such a transpose
/// explains the thesis's CGNR finding; our CGNR uses the true adjoint (tested in
/// `wavelux-solver`'s `transpose_is_the_adjoint_of_k`).
struct TransposeAsK<'a>(wavelux::solver::system::ChannelOperator<'a>);

impl Operator for TransposeAsK<'_> {
    fn dim(&self) -> usize {
        self.0.dim()
    }
    fn apply(&self, x: &[f64], y: &mut [f64]) {
        self.0.apply(x, y);
    }
    fn apply_transpose(&self, x: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        self.0.apply(x, y);
        Ok(())
    }
}

/// `K` in Ziegler's unknowns, the leaf cell averages `u = S x` (`S = diag(1/√A_leaf)`;
/// ours are orthonormal coefficients `x`): `A_u = S K S⁻¹`. Its transpose is either the
/// exact one, `S⁻¹ Kᵀ S`, or Ziegler's `D⁻ M_uᵀ D` (§2.3.3, §4.2: reconstruction after
/// the transposed cell-average link matrix after decomposition), which in `x` reads
/// `push · A Mᵀ A⁻¹ · pull` (`A` the node areas) and equals `Kᵀ` only when every node
/// has the same area. Tests the candidate explanation of the thesis's "CGNR never beats
/// Picard": an inexact transpose costs CGNR its minimisation property.
struct CellAverages<'a> {
    sys: &'a System,
    ch: usize,
    /// `1/√A` per leaf coefficient.
    s: Vec<f64>,
    ziegler_transpose: bool,
}

impl<'a> CellAverages<'a> {
    fn new(sys: &'a System, ch: usize, ziegler_transpose: bool) -> Self {
        let n = sys.hierarchy().n();
        let s = sys
            .hierarchy()
            .leaves()
            .iter()
            .flat_map(|&i| std::iter::repeat_n(1.0 / sys.node_area[i as usize].sqrt(), n))
            .collect();
        Self {
            sys,
            ch,
            s,
            ziegler_transpose,
        }
    }

    /// `u = S x`.
    fn to_u(&self, x: &[f64]) -> Vec<f64> {
        x.iter().zip(&self.s).map(|(x, s)| x * s).collect()
    }
}

impl Operator for CellAverages<'_> {
    fn dim(&self) -> usize {
        self.sys.dim()
    }
    fn apply(&self, u: &[f64], y: &mut [f64]) {
        let x: Vec<f64> = u.iter().zip(&self.s).map(|(u, s)| u / s).collect();
        self.sys.apply_k(self.ch, &x, y);
        y.iter_mut().zip(&self.s).for_each(|(y, s)| *y *= s);
    }
    fn apply_transpose(&self, u: &[f64], y: &mut [f64]) -> Result<(), Unsupported> {
        let sys = self.sys;
        if !self.ziegler_transpose {
            let t = self.to_u(u);
            sys.apply_kt(self.ch, &t, y);
            y.iter_mut().zip(&self.s).for_each(|(y, s)| *y /= s);
            return Ok(());
        }
        let n = sys.hierarchy().n();
        let rx: Vec<f64> = u
            .iter()
            .zip(&self.s)
            .enumerate()
            .map(|(j, (u, s))| sys.leaf_rho[j / n][self.ch] * u / s)
            .collect();
        let nn = sys.hierarchy().node_count() * n;
        let mut v = vec![0.0; nn];
        sys.pull_from_leaves(&rx, &mut v);
        v.iter_mut()
            .enumerate()
            .for_each(|(j, v)| *v /= sys.node_area[j / n]);
        let mut g = vec![0.0; nn];
        sys.scatter_transpose(&v, &mut g);
        g.iter_mut()
            .enumerate()
            .for_each(|(j, g)| *g *= sys.node_area[j / n]);
        sys.push(&mut g);
        for (l, &i) in sys.hierarchy().leaves().iter().enumerate() {
            for a in 0..n {
                y[l * n + a] = g[i as usize * n + a] * self.s[l * n + a];
            }
        }
        Ok(())
    }
}

/// Errors per iteration in Ziegler's unknowns (cell averages).
struct CellAverageRuns {
    picard: Vec<f64>,
    cgnr_exact: Vec<f64>,
    cgnr_ziegler: Vec<f64>,
    /// `‖(T_Ziegler − Kᵀ) b‖ / ‖Kᵀ b‖` in cell averages.
    difference: f64,
}

/// Picard and CGNR errors in Ziegler's unknowns (cell averages), with the exact and
/// with Ziegler's transpose, and the relative difference of the two transposes applied
/// to `b`.
fn cell_average_runs(
    system: &System,
    xref: &[f64],
    iters: usize,
) -> anyhow::Result<CellAverageRuns> {
    let exact = CellAverages::new(system, 0, false);
    let ziegler = CellAverages::new(system, 0, true);
    let b = exact.to_u(&system.emission(0));
    let (mut te, mut tz) = (vec![0.0; b.len()], vec![0.0; b.len()]);
    exact.apply_transpose(&b, &mut te)?;
    ziegler.apply_transpose(&b, &mut tz)?;
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    let diff: Vec<f64> = te.iter().zip(&tz).map(|(a, b)| a - b).collect();
    let difference = norm(&diff) / norm(&te);
    let opts = SolverOptions::default()
        .with_max_iterations(iters)
        .with_tolerance(0.0)
        .with_initial_guess(b.clone())
        .with_reference(exact.to_u(xref));
    let picard = errors(&picard_solve(&exact, &b, &opts)?.history);
    let cg_exact = errors(&cgnr_solve(&IdentityMinus::new(&exact), &b, &opts)?.history);
    let cg_ziegler = errors(&cgnr_solve(&IdentityMinus::new(&ziegler), &b, &opts)?.history);
    Ok(CellAverageRuns {
        picard,
        cgnr_exact: cg_exact,
        cgnr_ziegler: cg_ziegler,
        difference,
    })
}

fn min_ratio(a: &[f64], b: &[f64], iters: usize) -> f64 {
    (1..=iters)
        .map(|k| a.get(k).copied().unwrap_or(f64::NAN) / b[k])
        .fold(f64::INFINITY, f64::min)
}

fn errors(conv: &wavelux::linear::Convergence) -> Vec<f64> {
    conv.iterations
        .iter()
        .map(|r| r.error.unwrap_or(f64::NAN))
        .collect()
}

/// Iterations of every compared solver (the thesis plots 10).
const ITERS: usize = 10;

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut report = Report {
        paper_did: "Ziegler §4.2 solves the Haar wavelet radiosity system (ε = 1e-4, m = 5 \
levels, n_samp = 3, non-standard form) of a 3-unit box lit by a 1×1 emitting part of the \
ceiling, without (Fig. 4.10) and with (Fig. 4.11) a unit cube inside, at high (ρ_avg 0.52) \
and low (0.35) reflectance, with Picard, GMRES and CGNR from the initial guess b, and plots \
the error against a Picard solution after 80 iterations, error = ‖x_k − x̂‖₂/‖x̂‖₂ on the \
unknown vector (Figs. 4.12–4.15). Findings: after three iterations GMRES's error is ≈ 1/25 \
of Picard's (unoccluded) and ≈ 1/9, 1/5 (occluded); three GMRES iterations match more than \
8 Picard iterations (high ρ) and 5–6 (low ρ); CGNR never beats Picard. Computed links: \
484 452 / 283 272 / 898 016 / 606 398 of 2 516 580 / 10 066 320 potential."
            .into(),
        ..Report::default()
    };
    let max_level: u8 = if ctx.quick { 3 } else { 5 };
    let cfg = SolverConfig {
        basis: BasisKind::Haar,
        eps: OUR_EPS,
        max_level,
        quad_points: 3,
        oracle: Oracle::Reflectance,
        ..SolverConfig::default()
    };
    report.param("basis", "Haar");
    report.param("ε (oracle on ρ·G·V, ours; thesis 1e-4)", cfg.eps);
    report.param("max level m", max_level);
    report.param("n_samp (Gauss points per axis)", cfg.quad_points);
    report.param("visibility", "in quadrature (one ray per sample pair)");
    report.param("reference", "Picard, 80 iterations from b (as Ziegler)");
    report.param("GMRES restart", 30);
    report.param("S9 variant", "(a), ρ = 0.4");
    let mut table_rows = Vec::new();
    let mut link_rows = Vec::new();
    for (ci, case) in CASES.iter().enumerate() {
        let runs = CaseRuns::new(case, &cfg)?;
        push_rows(&mut report, ci, case, &runs);
        link_rows.push(vec![
            case.label.to_string(),
            format!("{}", PAPER_LINKS[ci]),
            format!("{}", runs.computed_links),
            format!("{}", runs.stored_blocks),
            format!("{}", PAPER_POTENTIAL[if case.cube { 1 } else { 0 }]),
            format!("{}", runs.potential),
            format!("{}", runs.patches),
            format!("{:.1}", runs.t_refine),
        ]);
        for k in 0..=ITERS {
            table_rows.push(vec![
                case.label.to_string(),
                k.to_string(),
                format!("{:.3e}", runs.picard[k]),
                format!("{:.3e}", runs.gmres[k]),
                format!("{:.3e}", runs.cgnr[k]),
                format!("{:.3e}", runs.gs.get(k).copied().unwrap_or(f64::NAN)),
            ]);
        }
        push_figure(ctx, &mut report, ci, case, &runs)?;
    }
    report.tables.push(Table {
        title: "Link counts".into(),
        headers: [
            "scene",
            "Ziegler computed",
            "ours (Ziegler's count)",
            "ours (stored blocks)",
            "Ziegler potential",
            "ours potential",
            "our patches",
            "refine + assembly CPU time (s)",
        ]
        .map(String::from)
        .to_vec(),
        rows: link_rows,
    });
    report.tables.push(Table {
        title: "Errors per iteration".into(),
        headers: ["scene", "k", "Picard", "GMRES", "CGNR", "Gauss-Seidel"]
            .map(String::from)
            .to_vec(),
        rows: table_rows,
    });
    report.we_did = we_did_text(max_level);
    Ok(report)
}

/// Everything measured on one case: the hierarchy's counts and the error curves
/// (index k: after k iterations, against 80 Picard iterations) of every solver.
struct CaseRuns {
    picard: Vec<f64>,
    gmres: Vec<f64>,
    cgnr: Vec<f64>,
    gs: Vec<f64>,
    /// CGNR with K in place of its transpose (hypothesis test).
    cgnr_k_as_t: Vec<f64>,
    /// Picard and CGNR in Ziegler's unknowns (leaf cell averages).
    cell: CellAverageRuns,
    /// Links computed, Ziegler's count (refined plus unrefined roots).
    computed_links: f64,
    /// Stored link blocks.
    stored_blocks: usize,
    /// Potential links over `max_level` levels of the patches.
    potential: f64,
    patches: usize,
    /// Refinement and assembly CPU time (s), context for the link table.
    t_refine: f64,
}

impl CaseRuns {
    /// Builds the case's system and runs every solver on its first channel.
    fn new(case: &Case, cfg: &SolverConfig) -> anyhow::Result<Self> {
        let scene = ziegler_box(case.cube, case.refl, BoxVariant::A);
        let t0 = crate::cpu::Stopwatch::start();
        let prep = Prepared::new(&scene, cfg)?;
        let tctx = prep.transfer()?;
        let params = prep.refine_params(cfg.eps);
        let (links, counts) = hierarchy::refine_all(&tctx, &params, &|_| 1.0);
        let h = Hierarchy::compile(prep.basis.n(), prep.patches.patches.len(), &links);
        drop(links);
        let system = System::new(h, &prep.basis, &prep.patches.patches);
        let t_refine = t0.elapsed().cpu_or_wall();
        let (xref, _) = solve_channel(&system, 0, LinearMethod::Picard, 80, 0.0, None, None)?;
        let run = |m: LinearMethod| -> anyhow::Result<Vec<f64>> {
            let (_, c) = solve_channel(&system, 0, m, ITERS, 0.0, None, Some(xref.clone()))?;
            Ok(errors(&c))
        };
        let cgnr_k_as_t = {
            let opts = SolverOptions::default()
                .with_max_iterations(ITERS)
                .with_tolerance(0.0)
                .with_initial_guess(system.emission(0))
                .with_reference(xref.clone());
            let op = TransposeAsK(system.channel(0));
            errors(&cgnr_solve(&IdentityMinus::new(&op), &system.emission(0), &opts)?.history)
        };
        let np = prep.patches.patches.len() as f64;
        Ok(Self {
            picard: run(LinearMethod::Picard)?,
            gmres: run(LinearMethod::Gmres { restart: 30 })?,
            cgnr: run(LinearMethod::Cgnr)?,
            gs: run(LinearMethod::GaussSeidel)?,
            cgnr_k_as_t,
            cell: cell_average_runs(&system, &xref, ITERS)?,
            computed_links: (counts.refined + counts.unrefined_roots) as f64,
            stored_blocks: system.hierarchy().link_count(),
            potential: np
                * np
                * (0..cfg.max_level as u32)
                    .map(|l| 16f64.powi(l as i32))
                    .sum::<f64>(),
            patches: prep.patches.patches.len(),
            t_refine,
        })
    }
}

/// Picard iterations (interpolated in log error) needed to reach `target`; past the
/// last iteration, extrapolated with the last contraction factor.
fn picard_equivalent(picard: &[f64], target: f64) -> f64 {
    for k in 1..picard.len() {
        if picard[k] <= target {
            let (a, b) = (picard[k - 1].ln(), picard[k].ln());
            return (k - 1) as f64 + (a - target.ln()) / (a - b);
        }
    }
    let n = picard.len() - 1;
    let q = (picard[n] / picard[n - 1]).ln();
    n as f64 + (target / picard[n]).ln() / q
}

/// The compared rows of case `ci`: GMRES against Picard (the thesis's findings), CGNR
/// against Picard, and the transpose hypothesis tests.
fn push_rows(report: &mut Report, ci: usize, case: &Case, r: &CaseRuns) {
    let (picard, iters) = (&r.picard, ITERS);
    let ratio3 = picard[3] / r.gmres[3];
    let equiv = picard_equivalent(picard, r.gmres[3]);
    let cgnr_vs_picard = (1..=iters)
        .map(|k| r.cgnr[k] / picard[k])
        .fold(f64::INFINITY, f64::min);
    let cgnr_kt_vs_picard = (1..=iters)
        .map(|k| r.cgnr_k_as_t.get(k).copied().unwrap_or(f64::NAN) / picard[k])
        .fold(f64::INFINITY, f64::min);
    // Per operator application (CGNR applies K and Kᵀ each iteration).
    let cgnr_vs_picard_work = (1..=iters / 2)
        .map(|k| r.cgnr[k] / picard[2 * k])
        .fold(f64::INFINITY, f64::min);
    report.rows.push(Row::new(
        format!(
            "Picard error / GMRES error after 3 iterations, {}",
            case.label
        ),
        Some(PAPER_RATIO_3[ci]),
        ratio3,
        "",
        Tolerance::Factor(3.0),
    ));
    report.rows.push(Row::new(
        format!(
            "Picard iterations matching 3 GMRES iterations, {}",
            case.label
        ),
        Some(PAPER_PICARD_EQUIV[ci]),
        equiv,
        "iterations",
        match case.refl {
            Reflectivity::High => Tolerance::AtLeast(8.0),
            _ => Tolerance::Absolute(1.5),
        },
    ));
    report.rows.push(Row::new(
        format!(
            "min_k CGNR error / Picard error (k = 1..10), {}",
            case.label
        ),
        None,
        cgnr_vs_picard,
        "",
        Tolerance::AtLeast(1.0),
    ));
    report.rows.push(
        Row::new(
            format!(
                "min_k CGNR error at k / Picard error at 2k (k = 1..5, equal work), {}",
                case.label
            ),
            None,
            cgnr_vs_picard_work,
            "",
            Tolerance::Info,
        )
        .comment("< 1: CGNR ahead even counting its transpose application"),
    );
    report.rows.push(
        Row::new(
            format!(
                "min_k CGNR-with-Kᵀ:=K error / Picard error (k = 1..10), {}",
                case.label
            ),
            None,
            cgnr_kt_vs_picard,
            "",
            Tolerance::Info,
        )
        .comment(
            "hypothesis test: CGNR with K in place of its transpose; ≥ 1 would match \
                 the thesis's 'no advantage over Picard'",
        ),
    );
    report.rows.push(
        Row::new(
            format!(
                "‖(Ziegler's transpose − exact transpose) b‖ / ‖exact transpose b‖, {}",
                case.label
            ),
            None,
            r.cell.difference,
            "",
            Tolerance::Info,
        )
        .comment(
            "0 (to rounding) when every link joins nodes of equal area: then \
                 A Mᵀ A⁻¹ = Mᵀ and Ziegler's transpose is exact",
        ),
    );
    report.rows.push(
        Row::new(
            format!(
                "min_k CGNR error / Picard error in cell averages, exact transpose (k = 1..10), {}",
                case.label
            ),
            None,
            min_ratio(&r.cell.cgnr_exact, &r.cell.picard, iters),
            "",
            Tolerance::Info,
        )
        .comment(
            "control: Ziegler's unknowns (leaf cell averages) and error norm, CGNR with \
                 the exact transpose S⁻¹KᵀS",
        ),
    );
    report.rows.push(
            Row::new(
                format!(
                    "min_k CGNR error / Picard error in cell averages, Ziegler's transpose D⁻M_uᵀD (k = 1..10), {}",
                    case.label
                ),
                None,
                min_ratio(&r.cell.cgnr_ziegler, &r.cell.picard, iters),
                "",
                Tolerance::Info,
            )
            .comment(
                "hypothesis test: Ziegler's unknowns with his transpose (the transposed \
                 cell-average link matrix between decomposition and reconstruction); ≥ 1 \
                 would match the thesis's 'CGNR never beats Picard'; equal to the exact \
                 transpose's row when the difference row above is 0",
            ),
        );
    report.rows.push(
        Row::new(
            format!("computed links (Ziegler's count), {}", case.label),
            Some(PAPER_LINKS[ci]),
            r.computed_links,
            "links",
            Tolerance::Info,
        )
        .comment(
            "not a result: our ε (3e-4, not the thesis's 1e-4) was chosen to give link \
                 counts of the thesis's order, because the thesis does not state the \
                 normalisation of its estimate",
        ),
    );
}

/// Fig. 4.12–4.15 for case `ci`: every solver's error curve.
fn push_figure(
    ctx: &Ctx,
    report: &mut Report,
    ci: usize,
    case: &Case,
    r: &CaseRuns,
) -> anyhow::Result<()> {
    let pts = |v: &[f64]| -> Vec<(f64, f64)> {
        v.iter()
            .enumerate()
            .filter(|(_, e)| **e > 0.0)
            .map(|(k, e)| (k as f64, *e))
            .collect()
    };
    let fig = 12 + [0, 2, 1, 3][ci];
    let p = ctx.figure_path(&format!("fig4.{fig}.svg"));
    xy_plot(
        &p,
        &format!("Fig. 4.{fig}: convergence, {}", case.label),
        &Axis::linear("iteration"),
        &Axis::log("relative error vs Picard-80"),
        &[
            Series::new("Picard", pts(&r.picard), Style::LinePoints),
            Series::new("GMRES(30)", pts(&r.gmres), Style::LinePoints),
            Series::new("CGNR", pts(&r.cgnr), Style::LinePoints),
            Series::new("Gauss-Seidel (ours)", pts(&r.gs), Style::LinePoints),
        ],
    )?;
    report.figures.push(Figure {
        path: p,
        caption: format!(
            "Fig. 4.{fig} reproduced ({}): error ‖x_k − x̂‖/‖x̂‖ of the leaf coefficient \
vector against 80 Picard iterations, all methods started from b. Hierarchical \
Gauss–Seidel (sweeps over patches) added for comparison.",
            case.label
        ),
    });
    Ok(())
}

fn we_did_text(max_level: u8) -> String {
    format!(
        "We rebuilt both box scenes with `wavelux::scene::builtin::ziegler_box` (outer box \
[0,3]³, light = [1,2]² part of the ceiling with E = 100, inner unit cube [1,2]³; every \
choice documented there), refined links top-down with the kernel-smoothness oracle (Haar: \
difference of kernel samples at the two interval midpoints along each axis, averaged over \
the other three axes, maximum over axes, times √(|R||E|), times the receiver's ρ as in \
Ziegler's F = R G — his link counts differ between high and low ρ, so his estimate \
includes ρ; ε = 3e-4, see below), up to level {max_level} \
(Ziegler's m = 5 means 32×32 finest cells), with 3×3 Gauss points per element and one \
shadow ray per sample pair, and singular Sauter–Schwab rules where elements share an edge \
(Ziegler avoided such pairs). The hierarchical system (pull → gather → push, the \
non-standard operator) is solved from x₀ = b by Picard, GMRES(30) and CGNR of \
`wavelux-linear`, plus our hierarchical Gauss–Seidel; the reference is 80 Picard \
iterations. The error is the Euclidean norm of the leaf-coefficient difference, which \
equals the norm of the non-standard wavelet coefficients because the change of basis is \
orthogonal (Ziegler's \"without weighting by area\": no extra area weights). Ziegler's \
link count is the number of cell pairs whose 15 (16 on level 0) wavelet form factors were \
computed: our refined links plus unrefined root links; potential links are \
patches² × Σ_{{l<m}} 16^l. Deviation: ε. The thesis does not state the normalisation of \
its estimate; with ours ε = 1e-4 would refine almost every pair of the 3-unit box to the \
finest level (~10⁷ links at m = 5, beyond this run's budget), so we use ε = 3e-4, which \
gives link counts of the thesis's order; the convergence comparison depends on the \
operator's spectrum, which the thresholds barely change. Two hypothesis tests for the \
thesis's CGNR finding run on the same systems: CGNR with K applied in place of its \
transpose, and CGNR in Ziegler's unknowns (leaf cell averages u = x/√A, error measured on \
u) with the exact transpose and with Ziegler's D⁻M_uᵀD (§2.3.3, §4.2: the transposed \
cell-average link matrix between decomposition and reconstruction, which in our \
coordinates is push · A Mᵀ A⁻¹ · pull and differs from the transpose only where a link \
joins nodes of different area)."
    )
}
