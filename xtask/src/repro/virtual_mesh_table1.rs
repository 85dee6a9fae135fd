//! VirtualMesh §6.1, Table 1 and Fig. 11: complex polygons through the virtual mesh vs
//! the same scene triangulated, Haar wavelets, 99 % convergence.
//!
//! Paper (seed 001, Table 1, the opera on a Pentium III 633 MHz):
//!
//! | geometry | # input prim. | # final meshes | time (s) | memory (Mb) | # shooting surfaces |
//! |---|---|---|---|---|---|
//! | simple polygons | 32,429 | 819,109 | 952 | 203.5 | 9,358 |
//! | complex polygons | 17,272 | 550,159 | 482 | 140.3 | 6,776 |
//!
//! Ours: the procedural hall of [`wavelux::scene::virtual_mesh::opera_hall`] (walls
//! pierced by arched and rectangular windows, oculi, arched doors and partitions, plus
//! pilasters, cornices and benches so that the mix of complex and simple polygons is
//! the opera's: the tessellation has ≈ 1.88 primitives per input primitive) and
//! its constrained-Delaunay triangulation without Steiner points
//! ([`wavelux::scene::tessellated`], the stand-in for the paper's OpenGL tessellator),
//! both solved by [`wavelux::solver::shoot`] with identical settings in one process.

use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::{Ctx, fmt_num};
use wavelux::scene::virtual_mesh::{OPERA_BENCHES_PER_BAY, opera_hall};
use wavelux::scene::{TessellateOptions, tessellated};
use wavelux::solver::BasisKind;
use wavelux::solver::shoot::ShootConfig;

use super::virtual_mesh_common::{
    Measured, Quantity, convergence_figure, count, measure, ratio_rows,
};

/// Table 1, "simple polygons" row: input primitives, final meshes, time (s), memory
/// (Mb), shooting surfaces.
const PAPER_SIMPLE: [f64; 5] = [32_429.0, 819_109.0, 952.0, 203.5, 9_358.0];
/// Table 1, "complex polygons" row, same columns.
const PAPER_COMPLEX: [f64; 5] = [17_272.0, 550_159.0, 482.0, 140.3, 6_776.0];

const QUANTITIES: [Quantity; 5] = [
    Quantity::Input,
    Quantity::Leaves,
    Quantity::Time,
    Quantity::Memory,
    Quantity::Shooting,
];

/// The solver settings shared by both runs (the paper: "same minimum subdivision size
/// and subdivision oracle threshold").
/// Quick mode (CI) stops at 50 % and one level so that both solves take seconds; its
/// ratios describe the first shots only. Full mode stops at 90 %, not the paper's 99 %:
/// at 90 % the tessellated hall already needs 84 shots and ~1,000 s here (session 21,
/// ≈ 12 s per shot on the loaded shared machine), and a 99 % run of it, stopped after
/// 16 minutes in session 23, had not finished; 99 % is unmeasured.
fn config(quick: bool) -> ShootConfig {
    ShootConfig {
        basis: BasisKind::Haar,
        convergence: if quick { 0.5 } else { 0.90 },
        eps: 1e-1,
        max_level: if quick { 1 } else { 2 },
        min_area: 1e-3,
        max_shots: if quick { 40 } else { 600 },
        ..ShootConfig::default()
    }
}

/// Context for a ratio, per quantity (never a reason to pass).
fn comment(q: Quantity) -> Option<&'static str> {
    match q {
        Quantity::Input => Some(
            "a property of the scene, not of the method: the hall's furnishing (benches per \
             bay) was chosen to give the opera's mix, so this ratio is reported, not tested",
        ),
        Quantity::Time => Some(
            "CPU time of each run (all threads), measured side by side in one process on a \
             shared 2-core machine; the ratio, not the absolute value, is comparable",
        ),
        Quantity::Memory => Some(
            "ours is the solver's own byte count (element trees, hierarchy, vectors); the \
             paper's is process memory after the run",
        ),
        _ => None,
    }
}

fn table_row(label: &str, m: &Measured) -> Vec<String> {
    vec![
        label.into(),
        count(m.input_primitives),
        count(m.leaves),
        format!(
            "{} CPU ({} wall)",
            fmt_num(m.seconds),
            fmt_num(m.wall_seconds)
        ),
        fmt_num(m.bytes as f64 / 1e6),
        count(m.shooting_surfaces),
        format!("{:.4}", m.convergence),
    ]
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let (bays, storeys) = (1, 1);
    let scene = opera_hall(bays, storeys)?;
    let tess = tessellated(&scene, &TessellateOptions::default())?;
    let cfg = config(ctx.quick);
    let virt = measure(&scene, &cfg)?;
    let simple = measure(&tess, &cfg)?;

    let mut rep = Report {
        paper_did: "VirtualMesh §6.1 illuminates the opera (a model of Héré's 18th-century opera \
house, 17,272 complex polygons) once with every polygon handled as one virtual-mesh primitive \
and once triangulated by the OpenGL tessellator into 32,429 simple polygons, with Haar wavelets \
and no clustering, until 99 % of the emitted energy has been propagated (convergence rate \
(E_i − E_r)/E_i). Table 1 gives input primitives, final meshes, time, memory and the number of \
surfaces that shot; the virtual mesh halves the time and needs 45 % less memory and 38 % fewer \
shooting surfaces."
            .into(),
        we_did: format!(
            "The opera model is not available. We built a procedural hall with the same kind of \
geometry and, reconstructed from the paper's two counts, the opera's mix of simple and complex \
polygons (`wavelux::scene::virtual_mesh::opera_hall({bays}, {storeys})`: {bays} bays × \
{storeys} storeys; walls are complex polygons with a round-arched window or an arched door cut \
into the outer loop, a rectangular window and a round oculus; slabs with round light wells; \
window reveals; ceiling lights; plus pilasters, cornices and {OPERA_BENCHES_PER_BAY} benches per \
bay and storey, all parallelograms, so that the tessellation has {:.2} primitives per input \
primitive where the opera has 32,429/17,272 = 1.88; the bare hall `architecture` has ≈ 5 because \
its arched and round openings triangulate into ≈ 16 triangles each). The tessellated baseline is \
`wavelux::scene::tessellated` with default options: spade constrained Delaunay triangulation of \
the loops without Steiner points, arcs flattened to a sagitta of 1 % of the polygon's diagonal, \
exact parallelogram pairs merged — the stand-in for the OpenGL tessellator. Both scenes are \
solved by the linkless shooting solver (`wavelux::solver::shoot`, VirtualMesh Algorithm 1) with \
identical settings (Haar, ε = {}, at most {} levels, minimum element area {} m², {} % \
convergence; quick mode: 50 % and one level), one after the other in this process. We compare the \
ratios complex/simple of every column with the paper's; the input-primitive ratio is matched by \
construction and reported only; the absolute values are context (different scene, machine and \
memory measure). Memory is the solver's byte count (`Statistics::bytes`). Deviation: the hall \
is small ({} input primitives against the opera's 17,272) so that both solves fit in minutes on \
this shared 2-core machine; `opera_hall(100, 14)` would be of the opera's size. Deviation: \
{} % convergence instead of the paper's 99 %: the tessellated hall needed 84 shots and ~1,000 s \
to reach 90 % here (session 21), and a 99 % run stopped after 16 minutes (session 23) had not \
finished, so the paper's setting is unmeasured.",
            simple.input_primitives as f64 / virt.input_primitives as f64,
            cfg.eps,
            cfg.max_level,
            cfg.min_area,
            cfg.convergence * 100.0,
            virt.input_primitives,
            cfg.convergence * 100.0,
        ),
        ..Report::default()
    };
    rep.param("scene", format!("opera_hall({bays}, {storeys})"));
    rep.param("basis", "Haar");
    rep.param("convergence rate", cfg.convergence);
    rep.param("eps", cfg.eps);
    rep.param("max level", cfg.max_level);
    rep.param("min element area (m²)", cfg.min_area);
    rep.param("quick", ctx.quick);

    for (k, q) in QUANTITIES.iter().enumerate() {
        let mut rows = ratio_rows(
            *q,
            ("complex (virtual mesh)", &virt, Some(PAPER_COMPLEX[k])),
            ("simple (tessellated)", &simple, Some(PAPER_SIMPLE[k])),
            2.0,
            comment(*q),
        );
        if *q == Quantity::Input {
            // Matched by construction of the scene: context, never a pass.
            for r in &mut rows {
                *r = Row::new(&r.quantity, r.paper, r.ours, &r.unit, Tolerance::Info)
                    .comment(comment(*q).unwrap_or_default());
            }
        }
        rep.rows.extend(rows);
    }
    rep.rows.push(
        Row::new(
            "convergence rate reached, virtual mesh",
            Some(0.99),
            virt.convergence,
            "",
            Tolerance::AtLeast(cfg.convergence),
        )
        .comment("the run stops at the first shot reaching the target"),
    );
    rep.rows.push(Row::new(
        "convergence rate reached, tessellated",
        Some(0.99),
        simple.convergence,
        "",
        Tolerance::AtLeast(cfg.convergence),
    ));
    let headers = [
        "geometry",
        "# input prim.",
        "# final meshes",
        "time (s; ours: CPU, wall)",
        "memory (MB)",
        "# shooting surfaces",
        "convergence",
    ]
    .map(String::from)
    .to_vec();
    let paper_row = |label: &str, p: &[f64; 5]| {
        vec![
            label.to_string(),
            count(p[0] as usize),
            count(p[1] as usize),
            fmt_num(p[2]),
            fmt_num(p[3]),
            count(p[4] as usize),
            "0.99".into(),
        ]
    };
    rep.tables.push(Table {
        title: "Table 1 side by side (paper: the opera on a Pentium III; ours: the hall)".into(),
        headers,
        rows: vec![
            paper_row("paper, simple polygons", &PAPER_SIMPLE),
            paper_row("paper, complex polygons", &PAPER_COMPLEX),
            table_row("ours, tessellated", &simple),
            table_row("ours, virtual mesh", &virt),
        ],
    });
    rep.figures.push(convergence_figure(
        ctx,
        "convergence.svg",
        "Architecture: virtual mesh vs tessellated (Haar)",
        &[("virtual mesh", &virt), ("tessellated", &simple)],
    )?);
    Ok(rep)
}
