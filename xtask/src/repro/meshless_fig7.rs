//! Meshless §4.2, Fig. 7 and its frame times: the atrium relit by a moving spot light
//! from one precomputed transfer, against the path tracer at every light position.
//!
//! The paper (Q6600, 192k functions) shows screenshots (Fig. 7) and quotes per-frame
//! CPU times while the light moves: direct illumination 8–70 ms, the transport
//! product 5–54 ms, flattening for display 21–33 ms. It gives no error figure.
//!
//! Tolerances (issue 13 §1: derived from a stated accuracy, or why not), registered
//! before the session-27 run:
//! - indirect relative L1 against the path tracer, per spot, at most `0.05 + f_ref`:
//!   **derived**. Issue 15 states the method's accuracy at ε = 0.005 (this run's ε) as
//!   5 % relative L1 against the path tracer (Cornell box). The reference's own noise
//!   adds at most its floor `f_ref` to the measured L1 (triangle inequality:
//!   `‖ours − ref‖ ≤ ‖ours − truth‖ + ‖truth − ref‖`, and the floor is the expected
//!   `‖truth − ref‖`, [`super::meshless_common`]). The precomputation's own Monte
//!   Carlo noise (point placement and eq. (16)'s gather strata; the full run uses the
//!   crate's default 256 gather rays, the quick run 64) is part of the method's error as a
//!   user sees it, so it is not excused: each row prints it (a second precomputation
//!   with another seed differs from the first by `d`; two independent noises of equal
//!   size `σ` differ by about `√2·σ`, so `σ ≈ d/√2`) as information only. Session 27's
//!   first version added `d/√2` to the bound; the lead removed it before the next run,
//!   because a bound that widens with the judged method's own scatter cannot fail a
//!   noisy method.
//! - direct, pull-push + `S·e`, and flattening per frame at most the paper's upper ends
//!   (70, 54 and 33 ms), in CPU time: **not derived**. The paper gives ranges over its
//!   scenes with no breakdown by size and no thread count (its Q6600 has four cores,
//!   so its CPU time per frame may be up to 4× the wall time it quotes); our frames
//!   hold other sizes (fewer functions, and 4× the paper's 973k links in `S` at this
//!   run's ε, see the parameters). The bound is the claim "a frame's CPU phases run in
//!   tens of milliseconds", compared in our CPU time (one rayon thread in the committed
//!   runs: the CPU time of the frame on one core). Quick runs: info (far smaller
//!   frames).

use super::meshless_common::{
    FrameCpu, ViewPoint, at_points, energy_ratio, functions, precompute, reference_indirect,
    relative_l1, relight_timed, scene, view_grid, with_lights,
};
use crate::cpu::Stopwatch;
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::meshless::{
    CpuBackend, FlattenOperator, FrameTimes, MeshlessConfig, Relighter, SceneSurfaces,
};
use wavelux::param::glam::DVec3;
use wavelux::render::{PathTracer, ToneMap};
use wavelux::scene::{Light, Rgb, Scene};

/// Problem sizes of one mode.
struct Sizes {
    scene: &'static str,
    /// `R_coarse` (m; `None`: 5 % of the diagonal).
    r_coarse: Option<f64>,
    levels: usize,
    senders: usize,
    gather_rays: usize,
    points: usize,
    paths: u64,
}

const QUICK: Sizes = Sizes {
    scene: "atrium-s",
    r_coarse: Some(2.9),
    levels: 3,
    senders: 2,
    gather_rays: 64,
    points: 300,
    paths: 512,
};

/// The "full" run is reduced too (ours): 3/2 levels keep it within the shared 2-core
/// machine's ~20 minutes. It gathers with the crate's default 256 rays: at 64 the
/// gather strata's noise alone moved the three spots by 7.0 / 16.9 / 8.2 % between two
/// precomputation seeds (session 27's run), more than the 5 % being judged.
const FULL: Sizes = Sizes {
    scene: "atrium",
    r_coarse: None,
    levels: 3,
    senders: 2,
    gather_rays: 256,
    points: 1000,
    paths: 1024,
};

/// The three spots: the scene's own (far end, aiming down the courtyard), one above
/// the courtyard's centre aiming at the floor and the right arcade, one above the
/// camera aiming at the floor's far half (positions in metres, intensities in W/sr).
fn spots(own: &Light) -> Vec<Light> {
    vec![
        own.clone(),
        Light::spot(
            "centre spot",
            DVec3::new(12.0, 9.0, 6.0),
            DVec3::new(0.0, -1.0, 0.8),
            25f64.to_radians(),
            35f64.to_radians(),
            Rgb::grey(400.0),
        ),
        Light::spot(
            "entrance spot",
            DVec3::new(2.0, 9.0, 6.0),
            DVec3::new(1.0, -0.9, 0.0),
            20f64.to_radians(),
            30f64.to_radians(),
            Rgb([500.0, 420.0, 330.0]),
        ),
    ]
}

/// Issue 15's accuracy of the method at ε = 0.005 (relative L1 against the path
/// tracer), the first term of the L1 tolerance (module docs).
const ISSUE_ACCURACY: f64 = 0.05;

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let s = if ctx.quick { &QUICK } else { &FULL };
    let mut r = Report::default();
    let base = scene(s.scene)?;
    let own = base
        .lights
        .first()
        .cloned()
        .ok_or_else(|| anyhow::anyhow!("{} has no spot", s.scene))?;
    let query = SceneSurfaces::new(&base)?;
    let cfg = MeshlessConfig {
        receiver_levels: s.levels,
        sender_levels: s.senders,
        gather_rays: s.gather_rays,
        r_coarse: s.r_coarse,
        epsilon: 0.005,
        bounces: 8,
        bounce_epsilon: Some(0.005 / 100.0),
        ..MeshlessConfig::default()
    };
    // The second seed's solutions first (the noise term of the L1 tolerance), so that
    // only one precomputation is held at a time.
    let grid = view_grid(&base, &query, s.points)?;
    let second: Vec<Vec<[f64; 3]>> = {
        let (pre2, _) = precompute(
            &base,
            &MeshlessConfig {
                seed: 2,
                ..cfg.clone()
            },
        )?;
        let relighter = Relighter::new(&pre2, CpuBackend)?;
        spots(&own)
            .iter()
            .map(|spot| {
                let ind = relighter.relight(&query, std::slice::from_ref(spot))?;
                Ok(at_points(&ind, &grid.points))
            })
            .collect::<anyhow::Result<_>>()?
    };
    let (pre, pre_t) = precompute(&base, &cfg)?;
    let relighter = Relighter::new(&pre, CpuBackend)?;
    let flat_op = FlattenOperator::new(&pre.basis);
    r.param(
        "scene",
        format!(
            "builtin:{} ({} surfaces), camera at the x = 0 end",
            s.scene,
            base.surfaces.len()
        ),
    );
    r.param(
        "precompute",
        format!(
            "{} receiver / {} sender levels, R_coarse {}, {} gather rays, ε = 0.005, 8 \
             bounces (bounce threshold ε/100): {} functions, {} links in S, {:.1} CPU s \
             ({:.1} s wall); a second precomputation with seed 2 measures the \
             precomputation's noise (L1 tolerance)",
            s.levels,
            s.senders,
            s.r_coarse
                .map_or("5 % of the diagonal".to_string(), |r| format!("{r} m")),
            s.gather_rays,
            functions(&pre),
            pre.s.nnz(),
            pre_t.total.cpu_or_wall(),
            pre_t.total.wall
        ),
    );
    r.param(
        "timing",
        format!(
            "CPU time of each frame phase ({} rayon thread(s); the committed runs use one)",
            rayon::current_num_threads()
        ),
    );
    r.param(
        "reference",
        format!(
            "path-traced indirect irradiance at {} camera points, {} walks each",
            grid.points.len(),
            s.paths
        ),
    );
    r.paper_did = "Fig. 7 (top): the Sponza Atrium (66k triangles) relit in real time by a \
        moving local light from one precomputation (6/3 levels, ε = 0.025, 192k \
        functions). §4.2 quotes the CPU time per frame with a moving light: direct \
        illumination 8–70 ms, applying the transport operator 5–54 ms, flattening 21–33 \
        ms (Q6600, quad core). No error against a reference is given."
        .into();
    r.we_did = format!(
        "Our atrium stands in for Sponza (not redistributable). One precomputation; three \
         spots (the scene's own at the far end, one above the courtyard's centre, one \
         above the entrance); per spot: direct irradiance at the sender points by shadow rays, \
         e = P†E←, i = S·e (f32 CPU backend), flattening (§4.1), then n·i at {} camera \
         points against the independent path tracer's indirect-only estimate (same spot, \
         {} walks per point). ε = 0.005 (ours: our links are dimensionless with ρ/π \
         inside; at 0.025 they keep too little energy, see meshless-scaling), 8 bounces \
         with the bounce products thresholded at ε/100 (ours: the reference has every \
         bounce; see meshless-scaling's ablation rows) and reduced levels, for the \
         shared 2-core machine. Times are CPU times of this run's frames with fewer \
         functions than the paper's, compared against the paper's upper ends only. The \
         L1 tolerance is derived (module docs): issue 15's 5 % plus the reference's \
         noise floor; the precomputation's noise, measured with a second seed, is printed \
         beside it and not excused. Images: ours, the reference and |ours − \
         reference| per camera point, each auto-exposed.",
        grid.points.len(),
        s.paths
    );

    let mut table = Vec::new();
    let mut references = Vec::new();
    for (k, spot) in spots(&own).iter().enumerate() {
        let lights = std::slice::from_ref(spot);
        let (ind, cpu) = relight_timed(&pre, &relighter, &query, lights)?;
        let t = Stopwatch::start();
        let flat = ind.flatten(&flat_op);
        let flatten_ms = t.elapsed().cpu_or_wall() * 1e3;
        let ours = at_points(&ind, &grid.points);
        let flat_v: Vec<[f64; 3]> = grid
            .points
            .iter()
            .map(|&(x, n)| flat.irradiance_at(x, n))
            .collect();
        let lit = with_lights(&base, lights);
        let tracer = PathTracer::new(&lit)?;
        let reference = reference_indirect(&tracer, &grid.points, s.paths, 11 + k as u64)?;
        let (l1, floor) = relative_l1(&ours, &reference);
        let (l1_flat, _) = relative_l1(&flat_v, &reference);
        let times = ind.times;
        let (d, _) = relative_l1(
            &second[k],
            &ours.iter().map(|&m| (m, [0.0; 3])).collect::<Vec<_>>(),
        );
        let noise = d / std::f64::consts::SQRT_2;
        r.rows.push(
            Row::new(
                format!("indirect relative L1 vs path tracer, {}", spot.name),
                None,
                l1,
                "",
                Tolerance::AtMost(ISSUE_ACCURACY + floor),
            )
            .comment(format!(
                "tolerance {:.2} % (issue 15) + reference noise floor {:.2} %; \
                 precomputation noise {:.2} % (seeds 0 and 2 differ by {:.2} %, not in the \
                 bound); energy ours/ref {:.3}",
                100.0 * ISSUE_ACCURACY,
                100.0 * floor,
                100.0 * noise,
                100.0 * d,
                energy_ratio(&ours, &reference)
            )),
        );
        r.rows.push(Row::new(
            format!(
                "flattened indirect relative L1 vs path tracer, {}",
                spot.name
            ),
            None,
            l1_flat,
            "",
            Tolerance::Info,
        ));
        frame_rows(&mut r, ctx.quick, &spot.name, &cpu, &times, flatten_ms);
        table.push(vec![
            spot.name.clone(),
            format!("{:.2}", cpu.direct_ms),
            format!("{:.2}", cpu.transport_ms),
            format!("{flatten_ms:.2}"),
            format!("{:.2}", cpu.total_ms()),
            times.active_senders.to_string(),
            format!("{:.2} %", 100.0 * l1),
            format!("{:.2} %", 100.0 * l1_flat),
        ]);

        let err: Vec<[f64; 3]> = ours
            .iter()
            .zip(&reference)
            .map(|(o, (m, _))| [0, 1, 2].map(|c| (o[c] - m[c]).abs()))
            .collect();
        let refs: Vec<[f64; 3]> = reference.iter().map(|(m, _)| *m).collect();
        for (name, values, caption) in [
            ("ours", &ours, "ours (hierarchical n·i)"),
            ("reference", &refs, "path-traced reference"),
            ("error", &err, "|ours − reference|"),
        ] {
            let path = ctx.figure_path(&format!("spot{k}-{name}.png"));
            grid.image(values).write_png(&path, ToneMap::Auto)?;
            r.figures.push(Figure {
                path,
                caption: format!(
                    "{}: {caption}, indirect irradiance at the camera points",
                    spot.name
                ),
            });
        }
        references.push(reference);
    }
    drop(relighter);
    drop(flat_op);
    drop(pre);
    seed_criteria_rows(&mut r, &base, &query, &cfg, &grid.points, &own, &references)?;
    r.tables.push(Table {
        title: "Per-frame CPU times (ms) and indirect error".into(),
        headers: [
            "spot",
            "direct",
            "pull-push + S·e",
            "flatten",
            "relight (direct + pull-push + S·e)",
            "active senders",
            "rel. L1",
            "rel. L1 flattened",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: table,
    });
    Ok(r)
}

/// The frame-time rows of one spot against the paper's upper ends (module docs).
fn frame_rows(
    r: &mut Report,
    quick: bool,
    spot: &str,
    cpu: &FrameCpu,
    times: &FrameTimes,
    flatten_ms: f64,
) {
    // The quick run's frames are far smaller than the paper's, and its times on a
    // shared machine swing by 4× between runs (S·e 19.9 and 76 ms for the same
    // frame in session 21): there they are context; the full run gates them.
    let timing = |bound: f64| {
        if quick {
            Tolerance::Info
        } else {
            Tolerance::AtMost(bound)
        }
    };
    r.rows.push(Row::new(
        format!("direct illumination per frame (CPU), {spot}"),
        Some(70.0),
        cpu.direct_ms,
        "ms",
        timing(70.0),
    ));
    r.rows.push(
        Row::new(
            format!("pull-push + transport product S·e per frame (CPU), {spot}"),
            Some(54.0),
            cpu.transport_ms,
            "ms",
            timing(54.0),
        )
        .comment(format!(
            "wall: pull-push {:.2} ms, S·e {:.2} ms",
            times.pull_push_ms, times.transport_ms
        )),
    );
    r.rows.push(Row::new(
        format!("flattening per frame (CPU), {spot}"),
        Some(33.0),
        flatten_ms,
        "ms",
        timing(33.0),
    ));
}

/// The three spots' indirect error with the seed's link criteria alone
/// (`max_dropped_share: None`; the crate's default bounds the level-0 dropped share
/// since session 29), against the same references and tolerance: the rows that
/// measure the seed's criteria.
fn seed_criteria_rows(
    r: &mut Report,
    base: &Scene,
    query: &SceneSurfaces,
    cfg: &MeshlessConfig,
    points: &[ViewPoint],
    own: &Light,
    references: &[Vec<([f64; 3], [f64; 3])>],
) -> anyhow::Result<()> {
    let (pre, pre_t) = precompute(
        base,
        &MeshlessConfig {
            max_dropped_share: None,
            ..cfg.clone()
        },
    )?;
    let relighter = Relighter::new(&pre, CpuBackend)?;
    for (spot, reference) in spots(own).iter().zip(references) {
        let ind = relighter.relight(query, std::slice::from_ref(spot))?;
        let ours = at_points(&ind, points);
        let (l1, floor) = relative_l1(&ours, reference);
        r.rows.push(
            Row::new(
                format!(
                    "indirect relative L1 vs path tracer, {}, the seed's criteria",
                    spot.name
                ),
                None,
                l1,
                "",
                Tolerance::AtMost(ISSUE_ACCURACY + floor),
            )
            .comment(format!(
                "the same precomputation without the level-0 dropped-share bound: {} links \
                 in S, {:.1} CPU s; tolerance {:.2} % (issue 15) + reference noise floor \
                 {:.2} %; energy ours/ref {:.3}",
                pre.s.nnz(),
                pre_t.total.cpu_or_wall(),
                100.0 * ISSUE_ACCURACY,
                100.0 * floor,
                energy_ratio(&ours, reference)
            )),
        );
    }
    Ok(())
}
