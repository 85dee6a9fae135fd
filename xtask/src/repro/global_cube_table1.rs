//! GlobalCube §5, Table 1: the hierarchical global cube on the lounge scene (`64³`
//! RGB, `M = m0 + 2`), elements and times per refinement step.
//!
//! The paper's numbers (seed 000, Table 1; SGI, red channel 8 h 46 min in all):
//! level `m0 + 2`: 4096 elements, 1 min; `m0 + 1`: 13133, 14652, 14799, 14813, 14813
//! elements (7, 9, 8, 8, 8 min); `m0`: 46768, 64177, 65605, 65738 (1 h 30, 2 h 11,
//! 2 h 12, 2 h 12 min). The paper gives no threshold and no geometry: our lounge is
//! rebuilt from the caption (`wavelux_scene::volume_scenes`) and the threshold is ours
//! (33/255 of each quantity's range), so element counts are compared by their shape:
//! the share of candidate cells a level refines in the end (paper: `(14813 − 4096)/7 =
//! 1531` of 4096 at `m0 + 1`, `(65738 − 14813)/7 = 7275` of `8 · 1531 = 12248` at
//! `m0`) and the growth from a level's first step to its last (14813/13133 = 1.128,
//! 65738/46768 = 1.406).

use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::volume::backend::cpu::{AntiAlias, CpuProjector, Projection};
use wavelux::volume::{GlobalCubeConfig, StepRecord, VolumeGrid};

/// Paper: elements per step of level `m0 + 1` and `m0`.
const PAPER_M1: [f64; 5] = [13133.0, 14652.0, 14799.0, 14813.0, 14813.0];
/// See [`PAPER_M1`].
const PAPER_M0: [f64; 4] = [46768.0, 64177.0, 65605.0, 65738.0];

/// Elements refined at level `m` in the end (`(last − before)/7`) and the elements of
/// the level's first and last steps.
fn level_shape(steps: &[StepRecord], m: usize, before: usize) -> Option<(f64, f64, f64)> {
    let own: Vec<&StepRecord> = steps
        .iter()
        .filter(|s| s.kind == "refine" && s.level == m)
        .collect();
    let (first, last) = (own.first()?, own.last()?);
    Some((
        (last.elements - before) as f64 / 7.0,
        first.elements as f64,
        last.elements as f64,
    ))
}

/// The hierarchical lounge of Table 1 and Figs. 13–14: `gc-lounge-{n}` (its name,
/// scene and grid), levels 2, framebuffer cap `framebuffer`, every threshold 33/255,
/// both oracles, one Jacobi relaxation per step; the parameters go to `r` (the
/// scene's with `note` in parentheses).
pub(crate) fn lounge(
    r: &mut Report,
    n: usize,
    framebuffer: usize,
    note: &str,
) -> anyhow::Result<(String, wavelux::scene::Scene, VolumeGrid, GlobalCubeConfig)> {
    let name = format!("gc-lounge-{n}");
    let scene = wavelux::scene::builtin::builtin(&name)
        .ok_or_else(|| anyhow::anyhow!("no built-in {name}"))?;
    let grid = VolumeGrid::from_medium(&scene.media[0])?;
    let cfg = GlobalCubeConfig {
        levels: 2,
        framebuffer,
        ..GlobalCubeConfig::default()
    }
    .with_threshold(33.0);
    r.param("scene", format!("builtin:{name} ({note})"));
    r.param("levels L", cfg.levels);
    r.param("framebuffer cap", cfg.framebuffer);
    r.param(
        "thresholds",
        "33/255 of each range (source, opacity, face powers)",
    );
    r.param("oracle", "both (static first, then dynamic)");
    r.param(
        "relaxation",
        "Jacobi, 1 per step; lowpass and final solves to 1e-4",
    );
    Ok((name, scene, grid, cfg))
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut r = Report::default();
    // 64³ (the paper's) takes hours on the CPU projector here: the full run is 32³.
    let n = if ctx.quick { 16 } else { 32 };
    // The paper's 16², 32², 64² projection planes at m0+2, m0+1, m0 are side >> level
    // at 64³; capped at 4 (full, 32³, and quick, 16³: 4, 4, 4): at 32³ the level-0
    // transport with N = 8 or 16 exceeds the recorded transport's 1 GiB, and a
    // re-projected solve took more than 15 min (dev profile, N = 16, 2026-11-25).
    let (_, _, grid, cfg) = lounge(&mut r, n, 4, "RGB")?;
    r.param("threads (rayon)", rayon::current_num_threads());
    r.param(
        "build",
        if cfg!(debug_assertions) {
            "dev profile (opt-level 1): times are not release times"
        } else {
            "release"
        },
    );
    r.paper_did = "Hubeli et al. solve the lounge (two sofas, a semi-transparent table, \
        a lamp, a book, haze; 64³ RGB voxels) with the hierarchical global cube, M = m0 + \
        2, projection planes 16², 32², 64² per level, on an SGI (texture hardware). Table 1 \
        lists elements and minutes per refinement step; no threshold is stated."
        .into();
    r.we_did = format!(
        "Our lounge is rebuilt from the caption (`gc-lounge`, documented in \
         `wavelux_scene::volume_scenes`; not the paper's geometry) at {n}³ and solved by \
         `wavelux_volume::solve` on the CPU projector (exact chords). The threshold is \
         ours. Element counts are compared by shape (share of candidates refined per \
         level, growth from a level's first step to its last) with a factor-2 band \
         registered before the first run: the scene and the threshold differ from the \
         paper's, so only the shape can be expected to carry over. Times are info (a \
         different machine and a software projector). {}",
        if ctx.quick {
            "Quick mode runs 16³, whose levels have 64, 512 and 4096 cells; the paper's \
             shapes are for 64³."
        } else {
            ""
        }
    );

    let t = crate::cpu::Stopwatch::start();
    // The paper's projector: one ray per pixel from the receiver's centre.
    let projector = CpuProjector::new(Projection::Exact, AntiAlias::OFF);
    let sol = wavelux::volume::solve(&grid, &cfg, &projector, &mut |_| {})?;
    let elapsed = t.elapsed();
    let lowpass = sol.steps.first().map_or(0, |s| s.elements);
    let mut table = Vec::new();
    for s in &sol.steps {
        table.push(vec![
            s.kind.to_string(),
            s.level.to_string(),
            s.step.to_string(),
            s.elements.to_string(),
            s.static_refined.to_string(),
            s.dynamic_refined.to_string(),
            format!("{:.2}", s.seconds),
            format!(
                "{:.1e}",
                s.energy
                    .balance_error()
                    .map(f64::abs)
                    .iter()
                    .fold(0.0f64, |a, &b| a.max(b))
            ),
        ]);
    }
    r.tables.push(Table {
        title: format!("Solve steps ({n}³)"),
        headers: [
            "kind",
            "level",
            "step",
            "elements",
            "static",
            "dynamic",
            "seconds",
            "|balance|",
        ]
        .map(String::from)
        .to_vec(),
        rows: table,
    });
    r.tables.push(Table {
        title: "Paper, Table 1 (64³)".into(),
        headers: ["level", "elements per step"].map(String::from).to_vec(),
        rows: vec![
            vec!["m0 + 2".into(), "4096".into()],
            vec!["m0 + 1".into(), format!("{PAPER_M1:?}")],
            vec!["m0".into(), format!("{PAPER_M0:?}")],
        ],
    });

    r.rows.push(
        Row::new(
            "lowpass elements (m0 + 2)",
            Some((n as f64 / 4.0).powi(3)),
            lowpass as f64,
            "",
            Tolerance::Relative(0.0),
        )
        .comment("(side/4)³; the paper's 4096 at 64³"),
    );
    let shape1 = level_shape(&sol.steps, 1, lowpass);
    let (refined1, first1, last1) = shape1.unwrap_or((0.0, 0.0, 0.0));
    r.rows.push(Row::new(
        "share of m0+2 cells refined into m0+1",
        Some(1531.0 / 4096.0),
        refined1 / lowpass.max(1) as f64,
        "",
        Tolerance::Factor(2.0),
    ));
    r.rows.push(Row::new(
        "growth of m0+1 elements, last/first step",
        Some(14813.0 / 13133.0),
        if first1 > 0.0 { last1 / first1 } else { 0.0 },
        "",
        Tolerance::Factor(2.0),
    ));
    let (refined0, first0, last0) =
        level_shape(&sol.steps, 0, last1 as usize).unwrap_or((0.0, 0.0, 0.0));
    r.rows.push(Row::new(
        "share of m0+1 cells refined into m0",
        Some(7275.0 / 12248.0),
        refined0 / (8.0 * refined1).max(1.0),
        "",
        Tolerance::Factor(2.0),
    ));
    r.rows.push(Row::new(
        "growth of m0 elements, last/first step",
        Some(65738.0 / 46768.0),
        if first0 > 0.0 { last0 / first0 } else { 0.0 },
        "",
        Tolerance::Factor(2.0),
    ));
    let bal = sol
        .energy
        .balance_error()
        .map(f64::abs)
        .iter()
        .fold(0.0f64, |a, &b| a.max(b));
    r.rows.push(
        Row::new(
            "energy balance |emitted − absorbed − escaped| / emitted, worst channel",
            None,
            bal,
            "",
            Tolerance::AtMost(0.02),
        )
        .comment("the model conserves energy up to the projector's discretisation (crate docs)"),
    );
    r.rows.push(Row::new(
        "final elements",
        Some(65738.0),
        sol.elements() as f64,
        "",
        Tolerance::Info,
    ));
    r.rows.push(
        Row::new(
            "CPU time of the whole solve (RGB)",
            Some(8.0 * 3600.0 + 46.0 * 60.0),
            elapsed.cpu_or_wall(),
            "s",
            Tolerance::Info,
        )
        .comment(format!(
            "CPU time of the process (wall {:.1} s); paper: red channel only, SGI, wall; \
             target of issue 14 §8: 64³ RGB < 60 s on 2 cores",
            elapsed.wall
        )),
    );
    Ok(r)
}
