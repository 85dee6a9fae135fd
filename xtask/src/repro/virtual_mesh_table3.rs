//! VirtualMesh §6.3, Table 3: constant-Jacobian (equal-area) mappings with precomputed
//! push/pull vs natural-coordinate mappings whose push/pull coefficients are integrated
//! per element with 5×5, 10×10 and 30×30 Gauss points, on the chess set, linear
//! wavelets (M2), 90 % convergence.
//!
//! Paper (seed 001, Table 3, Pentium III 633 MHz):
//!
//! | mappings | # quadrature points for push-pull | time (s) | memory (Mb) |
//! |---|---|---|---|
//! | non-constant Jacobian | 5×5 | 304 | 18.3 |
//! | | 10×10 | 402 | |
//! | | 30×30 | 755 | |
//! | constant Jacobian | 30×30 | 181 | 8.1 |
//!
//! Ours: [`wavelux::scene::virtual_mesh::chess_set_files`] solved by
//! [`wavelux::solver::shoot`] with `PushPull::Precomputed` and
//! `PushPull::Natural { gauss }` for gauss = 5, 10, 30, side by side in one process;
//! the solutions are compared surface by surface.
//!
//! Tolerances (issue 13 §1): the ratio rows, see `virtual_mesh_common` (**not
//! derived**). Solution difference natural vs constant `≤ 5 %`: **not derived**: the
//! paper states only that the images agree; both are discretisations of one equation
//! stopped at ≥ 90 % convergence, and 5 % is our judgment of "agree" for per-surface
//! means. Convergence reached `≥ 0.90`: **derived** (the paper's stopping rule).

use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::{Ctx, fmt_num};
use wavelux::scene::virtual_mesh::chess_set_files;
use wavelux::scene::{Scene, Shape};
use wavelux::solver::shoot::twoscale::TwoScale;
use wavelux::solver::shoot::{PushPull, ShootConfig};
use wavelux::solver::{BasisKind, NodeKey, ParamKind, TreeBasis, build_patches_with};

use super::virtual_mesh_common::{
    Measured, Quantity, convergence_figure, count, measure, ratio_rows, surface_difference,
};

/// Table 3: times (s) of the natural-coordinate runs with 5×5, 10×10, 30×30 points.
const PAPER_NATURAL_TIME: [f64; 3] = [304.0, 402.0, 755.0];
/// Table 3: time (s) of the constant-Jacobian run (30×30 points for top-level
/// coefficients only).
const PAPER_CONSTANT_TIME: f64 = 181.0;
/// Table 3: memory (Mb) of the natural-coordinate runs (given once, for 5×5) and of the
/// constant-Jacobian run.
const PAPER_MEMORY: [f64; 2] = [18.3, 8.1];
/// Gauss points per axis of the natural-coordinate push/pull.
const GAUSS: [usize; 3] = [5, 10, 30];

fn config(push_pull: PushPull, quick: bool) -> ShootConfig {
    ShootConfig {
        basis: BasisKind::Multiwavelet(2),
        convergence: 0.90,
        eps: if quick { 1e-1 } else { 5e-2 },
        max_level: if quick { 2 } else { 4 },
        min_area: 5e-6,
        max_shots: 200_000,
        push_pull,
        ..ShootConfig::default()
    }
}

fn row(label: &str, points: &str, m: &Measured) -> Vec<String> {
    vec![
        label.into(),
        points.into(),
        format!(
            "{} CPU ({} wall)",
            fmt_num(m.seconds),
            fmt_num(m.wall_seconds)
        ),
        fmt_num(m.bytes as f64 / 1e6),
        count(m.leaves),
        count(m.shots),
        format!("{:.4}", m.convergence),
    ]
}

/// Gauss orders whose push/pull matrices are compared with [`RULE_REFERENCE`]'s.
const RULE_ORDERS: [usize; 5] = [1, 2, 3, 5, 10];
/// The finest rule of Table 3 (30 × 30), the reference of the matrix comparison.
const RULE_REFERENCE: usize = 30;

/// What the push/pull Gauss order changes in the operators themselves: the largest
/// entry difference between the natural-coordinate push/pull matrices at `gauss` and
/// at [`RULE_REFERENCE`] points per axis, over every node of levels `0..levels` of
/// every curved patch (natural-coordinate supports; the flat ones have a constant
/// Jacobian and the same matrices at any order). Entries are `O(1)` (orthonormal
/// functions), so the value is a relative error of the operator.
fn push_pull_rule_differences(
    scene: &Scene,
    basis: BasisKind,
    levels: u8,
) -> anyhow::Result<Vec<(usize, f64)>> {
    let set = build_patches_with(scene, ParamKind::Natural)?;
    let tree = TreeBasis::new(basis)?;
    let reference = TwoScale::new(
        PushPull::Natural {
            gauss: RULE_REFERENCE,
        },
        &tree,
        &set.patches,
    )?;
    let curved: Vec<usize> = (0..set.patches.len())
        .filter(|&i| {
            matches!(
                scene.surfaces[set.patches[i].surface].shape,
                Shape::Patch(_)
            )
        })
        .collect();
    let mut out = Vec::new();
    for g in RULE_ORDERS {
        let ops = TwoScale::new(PushPull::Natural { gauss: g }, &tree, &set.patches)?;
        let mut worst: f64 = 0.0;
        for &patch in &curved {
            for level in 0..levels {
                let side = 1u32 << level;
                for iy in 0..side {
                    for ix in 0..side {
                        let key = NodeKey {
                            level,
                            patch: patch as u32,
                            iy,
                            ix,
                        };
                        let (a, b) = (ops.mats(&key), reference.mats(&key));
                        for c in 0..4 {
                            for (x, y) in a.pull[c]
                                .iter()
                                .chain(&a.push[c])
                                .zip(b.pull[c].iter().chain(&b.push[c]))
                            {
                                worst = worst.max((x - y).abs());
                            }
                        }
                    }
                }
            }
        }
        out.push((g, worst));
    }
    Ok(out)
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let files = 1;
    let scene = chess_set_files(files)?;
    let constant = measure(&scene, &config(PushPull::Precomputed, ctx.quick))?;
    let mut natural = Vec::new();
    for g in GAUSS {
        natural.push(measure(
            &scene,
            &config(PushPull::Natural { gauss: g }, ctx.quick),
        )?);
    }
    let curved = scene
        .surfaces
        .iter()
        .filter(|s| matches!(s.shape, Shape::Patch(_)))
        .count();
    let trimmed = scene
        .surfaces
        .iter()
        .filter(|s| matches!(&s.shape, Shape::Patch(p) if p.trim.is_some()))
        .count();
    let cfg = config(PushPull::Precomputed, ctx.quick);
    let mut rep = Report {
        paper_did: "VirtualMesh §6.3 lights a chess set (board and pieces, 555 surface patches of \
which 264 are curved, some with non-trivial trims such as the knight) with a desk lamp and \
solves it with linear wavelets to a 90 % convergence rate twice: with constant-Jacobian \
(equal-area) mappings, whose push/pull coefficients are level-independent and precomputed, and \
with natural-coordinate mappings, whose push/pull coefficients must be integrated at every \
level with 5×5, 10×10 or 30×30 Gauss points (the algorithm does not converge below 5×5; 10×10 \
are needed for a satisfactory image). Table 3: the constant-Jacobian run takes 181 s and 8.1 Mb, \
the natural ones 304/402/755 s and 18.3 Mb."
            .into(),
        we_did: we_did_text(&scene, files, curved, trimmed, &cfg),
        ..Report::default()
    };
    record_params(&mut rep, &scene, files, curved, &cfg, ctx.quick);
    cost_rows(&mut rep, &constant, &natural);
    solution_rows(&mut rep, &scene, &cfg, &constant, &natural)?;
    convergence_rows(&mut rep, &constant, &natural);
    rep.tables.push(side_by_side(&constant, &natural));
    rep.figures.push(convergence_figure(
        ctx,
        "convergence.svg",
        "Chess set: constant vs natural Jacobian (M2)",
        &[
            ("constant Jacobian", &constant),
            ("natural 10×10", &natural[1]),
        ],
    )?);
    Ok(rep)
}

/// The run's parameters, for the report.
fn record_params(
    rep: &mut Report,
    scene: &Scene,
    files: usize,
    curved: usize,
    cfg: &ShootConfig,
    quick: bool,
) {
    rep.param("chess files", files);
    rep.param("surfaces", scene.surfaces.len());
    rep.param("curved surfaces", curved);
    rep.param("basis", "M2");
    rep.param("convergence rate", cfg.convergence);
    rep.param("eps", cfg.eps);
    rep.param("max level", cfg.max_level);
    rep.param("min element area (m²)", cfg.min_area);
    rep.param("quick", quick);
}

/// Table 3's time and memory ratios, natural against constant Jacobian.
fn cost_rows(rep: &mut Report, constant: &Measured, natural: &[Measured]) {
    let time_comment = "CPU time of each run (all threads), all runs in one process; compare the \
                     ratio";
    for (k, g) in GAUSS.iter().enumerate() {
        let mut rows = ratio_rows(
            Quantity::Time,
            (
                &format!("natural {g}×{g}"),
                &natural[k],
                Some(PAPER_NATURAL_TIME[k]),
            ),
            ("constant Jacobian", constant, Some(PAPER_CONSTANT_TIME)),
            2.0,
            Some(time_comment),
        );
        if k > 0 {
            // The constant run's absolute row is already listed.
            rows.remove(1);
        }
        rep.rows.extend(rows);
    }
    let mem = ratio_rows(
        Quantity::Memory,
        ("natural 5×5", &natural[0], Some(PAPER_MEMORY[0])),
        ("constant Jacobian", constant, Some(PAPER_MEMORY[1])),
        2.0,
        Some(
            "ours counts the solver's bytes, including the per-element push/pull matrices the \
             natural variant stores; the paper's is process memory",
        ),
    );
    rep.rows.extend(mem);
}

/// What the Gauss order changes: the solutions against each other and the push/pull
/// matrices against the 30 × 30 rule.
fn solution_rows(
    rep: &mut Report,
    scene: &Scene,
    cfg: &ShootConfig,
    constant: &Measured,
    natural: &[Measured],
) -> anyhow::Result<()> {
    for (k, g) in GAUSS.iter().enumerate() {
        let d = surface_difference(&natural[k], constant);
        rep.rows.push(
            Row::new(
                format!("solution difference natural {g}×{g} vs constant (relative L1)"),
                None,
                d,
                "",
                Tolerance::AtMost(0.05),
            )
            .comment(
                "the paper shows the images agree; we require the per-surface mean radiosities \
                 to agree within 5 % (area-weighted L1)",
            ),
        );
    }
    // What the variable under test changes: the paper's 5×5 run did not converge and
    // needed 10×10 for a good image; ours is measured here, not assumed.
    rep.rows.push(
        Row::new(
            "solution difference natural 5×5 vs natural 30×30 (relative L1)",
            None,
            surface_difference(&natural[0], &natural[2]),
            "",
            Tolerance::Info,
        )
        .comment(
            "how much the push/pull Gauss order moves our solution: the natural variant \
             integrates the J-weighted Gram matrices per child cell, and J of our natural maps \
             (sphere cos φ, cone linear, torus R + r cos v) is smooth on a cell, so 5×5 may already \
             give the 30×30 solution",
        ),
    );
    // The mechanism, measured on the operators: how far each Gauss order's push/pull
    // matrices are from the 30 × 30 ones on the curved patches.
    for (g, d) in push_pull_rule_differences(scene, cfg.basis, cfg.max_level)? {
        rep.rows.push(
            Row::new(
                format!(
                    "push/pull matrices {g}×{g} vs {RULE_REFERENCE}×{RULE_REFERENCE}: largest \
                     entry difference (curved patches, levels 0–{})",
                    cfg.max_level - 1
                ),
                None,
                d,
                "",
                Tolerance::Info,
            )
            .comment(
                "VirtualMesh §5.2's H = A⁻¹B, G = C⁻¹D with the Gram matrices integrated by a \
                 g × g Gauss rule per child cell; the paper's run did not converge below 5×5",
            ),
        );
    }
    rep.rows.push(Row::new(
        "final meshes natural 5×5 / natural 30×30",
        None,
        natural[0].leaves as f64 / natural[2].leaves as f64,
        "",
        Tolerance::Info,
    ));
    Ok(())
}

/// The convergence rate each run reached (the paper's runs stop at 90 %).
fn convergence_rows(rep: &mut Report, constant: &Measured, natural: &[Measured]) {
    let mut reached = vec![("constant Jacobian".to_string(), constant)];
    for (g, m) in GAUSS.iter().zip(natural) {
        reached.push((format!("natural {g}×{g}"), m));
    }
    for (label, m) in reached {
        rep.rows.push(Row::new(
            format!("convergence rate reached, {label}"),
            Some(0.90),
            m.convergence,
            "",
            Tolerance::AtLeast(0.90),
        ));
    }
}

/// What we did, for the report.
fn we_did_text(
    scene: &Scene,
    files: usize,
    curved: usize,
    trimmed: usize,
    cfg: &ShootConfig,
) -> String {
    format!(
        "`wavelux::scene::virtual_mesh::chess_set_files({files})`: a board of 64 squares with \
a frame, {} pieces stacked from cylinders, cone frusta, spheres, spheroids and tori (rook \
towers trimmed with crenels, knight heads trimmed by a notched profile with an eye hole, \
bishop mitres with a slanted slot, queen crowns bitten by eight arcs), and a desk lamp (cone \
shade over an emitter disk): {} surfaces, {curved} curved, {trimmed} trimmed. Solved by \
`wavelux::solver::shoot` with M2 (linear) wavelets, ε = {}, at most {} levels, minimum element \
area {} m², to 90 % convergence, once with equal-area supports (`ParamKind::EqualArea`) and \
`PushPull::Precomputed`, and three times with natural-coordinate supports \
(`ParamKind::Natural`: curved patches mapped by their natural parameters, non-constant \
Jacobian) and `PushPull::Natural {{ gauss }}` for gauss = 5, 10, 30 (per-element push/pull \
integrated with gauss × gauss points per child cell), side by side in this process. We compare the time and memory ratios \
natural/constant with the paper's and check that the natural-coordinate solutions agree with \
the constant-Jacobian one (area-weighted relative L1 difference of the per-surface mean \
radiosities). Deviation: only the first file's four pieces stand on the board (the \
full 32-piece set, `chess_set()`, is built and tested but its solves take far longer than the \
few minutes budgeted for a reproduction on this shared 2-core machine), and the solver's \
settings are coarse for the same reason.",
        4 * files,
        scene.surfaces.len(),
        cfg.eps,
        cfg.max_level,
        cfg.min_area,
    )
}

/// Table 3 side by side: the paper's rows and ours.
fn side_by_side(constant: &Measured, natural: &[Measured]) -> Table {
    let mut rows = vec![
        vec![
            "paper, non-constant Jacobian".into(),
            "5×5".into(),
            fmt_num(PAPER_NATURAL_TIME[0]),
            fmt_num(PAPER_MEMORY[0]),
            "—".into(),
            "—".into(),
            "0.90".into(),
        ],
        vec![
            "paper, non-constant Jacobian".into(),
            "10×10".into(),
            fmt_num(PAPER_NATURAL_TIME[1]),
            "—".into(),
            "—".into(),
            "—".into(),
            "0.90".into(),
        ],
        vec![
            "paper, non-constant Jacobian".into(),
            "30×30".into(),
            fmt_num(PAPER_NATURAL_TIME[2]),
            "—".into(),
            "—".into(),
            "—".into(),
            "0.90".into(),
        ],
        vec![
            "paper, constant Jacobian".into(),
            "30×30".into(),
            fmt_num(PAPER_CONSTANT_TIME),
            fmt_num(PAPER_MEMORY[1]),
            "—".into(),
            "—".into(),
            "0.90".into(),
        ],
    ];
    for (k, g) in GAUSS.iter().enumerate() {
        rows.push(row(
            "ours, natural coordinates",
            &format!("{g}×{g}"),
            &natural[k],
        ));
    }
    rows.push(row("ours, constant Jacobian", "precomputed", constant));
    Table {
        title: "Table 3 side by side".into(),
        headers: [
            "mappings",
            "push-pull quadrature",
            "time (s; ours: CPU, wall)",
            "memory (MB)",
            "# final meshes",
            "shots",
            "convergence",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    }
}
