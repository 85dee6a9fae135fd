//! Shared machinery of the VirtualMesh §6 table reproductions (Tables 1–3): one timed
//! run of the linkless shooting solver (VirtualMesh §5, Algorithm 1) on a scene, the
//! numbers the paper tabulates, and the paper-vs-ours ratio rows.
//!
//! The paper's tables compare two variants of one scene (virtual mesh vs tessellated,
//! constant vs natural Jacobian) on a 633 MHz Pentium III; absolute times and memory
//! cannot transfer to our machine and our scenes, so each table is reproduced as the
//! *ratios* between the two variants measured side by side in one process, and the
//! absolute values are shown for context.
//!
//! Tolerances (issue 13 §1: derived from a stated accuracy, or why not): the ratio rows
//! of Tables 1–3 (`ours_a / ours_b` against `paper_a / paper_b` within a factor 2) are
//! **not derived**. The paper reports one run per row on other scenes (the opera, its
//! teapot, its chess set: ours are reconstructions, see each report) and another
//! machine, with no repeat or spread; a factor 2 is our judgment of how far a
//! reconstruction may move a ratio while still reproducing the claim (e.g. "halves the
//! time" stays below 1). Wall-time ratios measured here also move by up to ~3×
//! between runs on the shared machine (Table 3's natural 5×5 / constant: 3.07 in
//! session 21, 1.08 in session 23 at load ~16, where the runs got ~10 % of a core), so
//! the time rows compare the CPU time of each run ([`crate::cpu`]: all threads of the
//! process during the run, 10 ms resolution), with the wall time shown beside it.

use crate::cpu::Stopwatch;
use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Row, Tolerance};
use crate::reproduce::Ctx;
use wavelux::scene::Scene;
use wavelux::solver::shoot::{ShootConfig, shoot};

/// What one solver run measured.
#[derive(Debug, Clone)]
pub struct Measured {
    /// Input primitives of the scene (mesh elements; every other surface counts one):
    /// VirtualMesh's "# input prim.".
    pub input_primitives: usize,
    /// Leaf elements at the end: VirtualMesh's "# final meshes".
    pub leaves: usize,
    /// CPU time of the whole solve (supports, accelerator, shooting; all threads),
    /// seconds; the wall time where `/proc` is unavailable.
    pub seconds: f64,
    /// Wall time of the same solve, seconds (context: it depends on the machine's load).
    pub wall_seconds: f64,
    /// Solver memory (`Statistics::bytes`: element trees, hierarchy, vectors), bytes.
    pub bytes: usize,
    /// Input primitives that shot at least once: VirtualMesh's "# shooting surfaces".
    pub shooting_surfaces: usize,
    /// Shots.
    pub shots: usize,
    /// Convergence rate `(E_i − E_r)/E_i` reached.
    pub convergence: f64,
    /// Convergence rate after each shot.
    pub curve: Vec<f64>,
    /// Mean radiosity (W/m², RGB mean) of every surface of the scene, in scene order.
    pub surface_mean: Vec<f64>,
    /// Area of every surface (m²), in scene order.
    pub surface_area: Vec<f64>,
}

/// Runs the shooting solver on `scene` with `config` and measures it; the time includes
/// the preparation (supports, accelerator, basis). `shoot` maps curved patches by their
/// equal-area parametrization for `PushPull::Precomputed` and by their natural
/// coordinates for `PushPull::Natural` (Table 3).
pub fn measure(scene: &Scene, config: &ShootConfig) -> anyhow::Result<Measured> {
    let sw = Stopwatch::start();
    let sol = shoot(scene, config)?;
    let t = sw.elapsed();
    let (seconds, wall_seconds) = (t.cpu_or_wall(), t.wall);
    let st = &sol.stats;
    eprintln!(
        "  {}: {} basis, {} shots, {} leaves, {seconds:.1} s CPU, {wall_seconds:.1} s wall",
        scene.name,
        config.basis.name(),
        st.shots,
        st.leaves
    );
    let surface_mean = (0..scene.surfaces.len())
        .map(|i| {
            let b = sol.surface_average(i);
            (b[0] + b[1] + b[2]) / 3.0
        })
        .collect();
    Ok(Measured {
        input_primitives: wavelux::scene::primitive_count(scene),
        leaves: st.leaves,
        seconds,
        wall_seconds,
        bytes: st.bytes,
        shooting_surfaces: st.shooting_surfaces,
        shots: st.shots,
        convergence: st.shot_convergence.last().copied().unwrap_or(0.0),
        curve: st.shot_convergence.clone(),
        surface_mean,
        surface_area: scene.surfaces.iter().map(|s| s.shape.area()).collect(),
    })
}

/// Area-weighted relative L1 difference of the per-surface mean radiosities of two
/// runs on scenes with the same surfaces (same order): `Σ A_i |a_i − b_i| / Σ A_i |b_i|`.
pub fn surface_difference(a: &Measured, b: &Measured) -> f64 {
    let mut num = 0.0;
    let mut den = 0.0;
    for ((x, y), w) in a
        .surface_mean
        .iter()
        .zip(&b.surface_mean)
        .zip(&b.surface_area)
    {
        num += w * (x - y).abs();
        den += w * y.abs();
    }
    if den > 0.0 { num / den } else { f64::NAN }
}

/// The quantities of a VirtualMesh §6 table row, in the paper's order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Quantity {
    /// "# input prim."
    Input,
    /// "# final meshes"
    Leaves,
    /// "computation time (s)"
    Time,
    /// "memory usage (Mb)"
    Memory,
    /// "# shooting surfaces"
    Shooting,
}

impl Quantity {
    /// Label used in rows.
    pub fn label(self) -> &'static str {
        match self {
            Self::Input => "input primitives",
            Self::Leaves => "final meshes (leaf elements)",
            Self::Time => "computation time",
            Self::Memory => "memory",
            Self::Shooting => "shooting surfaces",
        }
    }

    /// Our value and its unit.
    pub fn of(self, m: &Measured) -> (f64, &'static str) {
        match self {
            Self::Input => (m.input_primitives as f64, ""),
            Self::Leaves => (m.leaves as f64, ""),
            Self::Time => (m.seconds, "CPU s"),
            Self::Memory => (m.bytes as f64 / 1e6, "MB"),
            Self::Shooting => (m.shooting_surfaces as f64, ""),
        }
    }
}

/// Rows comparing `ours_a / ours_b` with `paper_a / paper_b` for one quantity
/// (`Tolerance::Factor(factor)`), plus the two absolute values of ours as context
/// rows (the paper's absolute values attached, `Tolerance::Info`). `comment` is context
/// for the reader; it never excuses a ratio outside `factor`.
pub fn ratio_rows(
    q: Quantity,
    (label_a, a, paper_a): (&str, &Measured, Option<f64>),
    (label_b, b, paper_b): (&str, &Measured, Option<f64>),
    factor: f64,
    comment: Option<&str>,
) -> Vec<Row> {
    let (va, unit) = q.of(a);
    let (vb, _) = q.of(b);
    let mut rows = vec![
        Row::new(
            format!("{}, {label_a}", q.label()),
            paper_a,
            va,
            unit,
            Tolerance::Info,
        ),
        Row::new(
            format!("{}, {label_b}", q.label()),
            paper_b,
            vb,
            unit,
            Tolerance::Info,
        ),
    ];
    let paper_ratio = match (paper_a, paper_b) {
        (Some(x), Some(y)) if y != 0.0 => Some(x / y),
        _ => None,
    };
    let tol = if paper_ratio.is_some() {
        Tolerance::Factor(factor)
    } else {
        Tolerance::Info
    };
    let mut r = Row::new(
        format!("{} ratio {label_a} / {label_b}", q.label()),
        paper_ratio,
        va / vb,
        "",
        tol,
    );
    if let Some(c) = comment {
        r = r.comment(c);
    }
    rows.push(r);
    rows
}

/// Plots convergence rate against shot number for labelled runs (the analogue of
/// VirtualMesh Fig. 11, which plots it against time).
pub fn convergence_figure(
    ctx: &Ctx,
    file: &str,
    title: &str,
    runs: &[(&str, &Measured)],
) -> anyhow::Result<Figure> {
    let styles = [Style::Line, Style::LinePoints];
    let series: Vec<Series> = runs
        .iter()
        .enumerate()
        .map(|(k, (label, m))| {
            let pts = m
                .curve
                .iter()
                .enumerate()
                .map(|(i, c)| ((i + 1) as f64, (1.0 - c).max(1e-6)))
                .collect();
            Series::new(*label, pts, styles[k % styles.len()])
        })
        .collect();
    let path = ctx.figure_path(file);
    xy_plot(
        &path,
        title,
        &Axis::log("shots"),
        &Axis::log("1 − convergence rate (E_r / E_i)"),
        &series,
    )?;
    Ok(Figure {
        path,
        caption: format!(
            "{title}: power left to shoot over emitted power after each shot (log–log)."
        ),
    })
}

/// Formats a count with thousands separators.
pub fn count(n: usize) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}
