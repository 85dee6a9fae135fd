//! Meshless §3.2, §4.2 ("Comparisons"): how the hierarchical direct-to-indirect
//! precomputation scales on the Cornell box: links and time against receivers, the
//! error against the points and against `ε`, and a dense one-level transfer against
//! the hierarchy at equal finest-level points.
//!
//! The paper quotes no curve: it states that the hierarchy computes only a small
//! fraction of the potential links (Table 1: 0.032–0.052 %) and gives "two orders of
//! magnitude faster precomputation" than the non-hierarchical method of Kristensen et
//! al. on the Sponza Atrium. Issue 15 registers the expectations checked here: links
//! and time grow about linearly with the receivers (exponent ≈ 1), the error falls as
//! `R_coarse` and `ε` shrink, and the indirect error on the Cornell box is at most 5 %
//! at `ε = 0.005` against the path tracer.

use super::meshless_common::{
    ViewPoint, at_points, energy_ratio, functions, log_slope, precompute, reference_indirect,
    relative_l1, scene, scene_direct,
};
use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::meshless::{
    CpuBackend, LinkThreshold, MeshlessConfig, Precomputed, Relighter, SceneSurfaces, SurfaceQuery,
};
use wavelux::param::glam::DVec3;
use wavelux::render::PathTracer;
use wavelux::scene::Scene;

/// Problem sizes of one mode.
struct Sizes {
    levels: usize,
    gather_rays: usize,
    emitter_samples: usize,
    points: usize,
    paths: u64,
    /// `R_coarse` of the point sweep (m), coarsest first.
    r_sweep: [f64; 3],
    /// `R_coarse` of the ε sweep and the error target (m).
    r_eps: f64,
    /// Levels and `R_coarse` of the dense-versus-hierarchy comparison.
    dense_levels: usize,
    dense_r: f64,
}

const QUICK: Sizes = Sizes {
    levels: 3,
    gather_rays: 64,
    emitter_samples: 32,
    points: 400,
    paths: 2048,
    r_sweep: [0.192, 0.136, 0.096],
    r_eps: 0.096,
    dense_levels: 2,
    dense_r: 0.136,
};

/// The "full" run is reduced too (ours): 128 gather rays and R_coarse ≥ 0.068 m (the
/// default is 0.048 m) keep it to a few minutes on the shared 2-core machine.
const FULL: Sizes = Sizes {
    levels: 3,
    gather_rays: 128,
    emitter_samples: 64,
    points: 1000,
    paths: 16384,
    r_sweep: [0.136, 0.096, 0.068],
    r_eps: 0.068,
    dense_levels: 3,
    dense_r: 0.136,
};

/// The ε of the sweep, largest first (issue 15: 0.1 … 0.005; 0.0025 is ours: what the
/// 5 % target costs with the seed's threshold).
const EPS: [f64; 6] = [0.1, 0.05, 0.025, 0.01, 0.005, 0.0025];

/// Bands of distance (m) from a point to the nearest face of the box's bounding box
/// other than its own plane (the walls, floor, ceiling and the open front).
const EDGE_BANDS: [(&str, f64, f64); 3] = [
    ("within 1.5 cm of another face of the box", -1.0, 0.015),
    ("1.5–7 cm from another face of the box", 0.015, 0.07),
    (
        "over 7 cm from every other face of the box",
        0.07,
        f64::INFINITY,
    ),
];

/// Distance from a point to the nearest face of the box `[lo, hi]` other than the
/// plane it lies on (the axis of its normal's largest component).
fn face_distance((x, n): ViewPoint, lo: DVec3, hi: DVec3) -> f64 {
    let own = n.abs().max_position();
    (0..3)
        .filter(|&a| a != own)
        .map(|a| (x[a] - lo[a]).abs().min((hi[a] - x[a]).abs()))
        .fold(f64::INFINITY, f64::min)
}

/// Values as an exact (zero-error) reference for [`relative_l1`].
fn exact_ref(v: &[[f64; 3]]) -> Vec<([f64; 3], [f64; 3])> {
    v.iter().map(|&m| (m, [0.0; 3])).collect()
}

/// Bounces of the runs: the path-traced reference has them all, and with the Cornell
/// box's reflectances the paper's four leave ~6 % of the indirect energy out (the
/// "4 bounces" ablation row measures it), so the error would measure the series'
/// truncation rather than the transfer.
const BOUNCES: usize = 8;

/// The runs' configuration: the seed's link criteria alone (`max_dropped_share:
/// None`; the crate's default bounds the level-0 dropped share since session 29), so
/// that the rows below measure the seed's criteria unless their label names a share.
fn config(s: &Sizes, r: f64, eps: f64) -> MeshlessConfig {
    MeshlessConfig {
        receiver_levels: s.levels,
        sender_levels: 2.min(s.levels),
        r_coarse: Some(r),
        gather_rays: s.gather_rays,
        epsilon: eps,
        threshold: LinkThreshold::Uniform,
        max_dropped_share: None,
        bounces: BOUNCES,
        bounce_epsilon: Some(eps / 100.0),
        ..MeshlessConfig::default()
    }
}

/// Level-0 dropped share of the bounded runs (ours, registered before their first
/// full run: `MeshlessConfig::max_dropped_share`).
const SHARE: f64 = 0.1;

/// The point sweep again with each level-0 receiver's dropped links bounded to
/// [`SHARE`] of its gathered mass: whether the error then falls with `R_coarse`, and
/// the error target at ε = 0.005 with the bound. `seed` holds the point sweep's runs
/// (the seed's criteria alone), finest last.
fn share_sweep(
    su: &Setup<'_>,
    seed: &[Run],
    quick: bool,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<()> {
    let s = su.s;
    let label = format!("level-0 dropped share ≤ {SHARE}");
    let mut runs = Vec::new();
    for &rc in &s.r_sweep {
        let cfg = MeshlessConfig {
            max_dropped_share: Some(SHARE),
            ..config(s, rc, 0.005)
        };
        let (run, _) = su.run(&cfg)?;
        table.push(run_row(
            format!("R_coarse = {rc} m, ε = 0.005, {label}"),
            &run,
        ));
        runs.push(run);
    }
    let list =
        |v: &[Run], f: &dyn Fn(&Run) -> String| v.iter().map(f).collect::<Vec<_>>().join(", ");
    r.rows.push(
        Row::new(
            format!("indirect error at the finest / coarsest R_coarse, {label}"),
            None,
            runs[2].l1 / runs[0].l1,
            "",
            Tolerance::AtMost(1.0),
        )
        .comment(format!(
            "the error falls as R_coarse shrinks: {} at R_coarse {:?} m (energy {}); the \
             seed's criteria alone: {} (energy {})",
            list(&runs, &|q| format!("{:.2} %", 100.0 * q.l1)),
            s.r_sweep,
            list(&runs, &|q| format!("{:.3}", q.energy)),
            list(seed, &|q| format!("{:.2} %", 100.0 * q.l1)),
            list(seed, &|q| format!("{:.3}", q.energy)),
        )),
    );
    let (fine, fine_seed) = (&runs[2], &seed[2]);
    r.rows.push(
        Row::new(
            format!("indirect relative L1 vs path tracer, Cornell box, ε = 0.005, {label}"),
            Some(0.05),
            fine.l1,
            "",
            issue_target(quick),
        )
        .comment(format!(
            "issue 15's target with the bound (ours; info in the quick run, whose \
             reference noise takes most of the 5 %); energy {:.3}, {} links in T, {} in S, \
             precompute {:.1} s (the seed's criteria: {:.3}, {}, {}, {:.1} s)",
            fine.energy,
            fine.t_links,
            fine.s_links,
            fine.seconds,
            fine_seed.energy,
            fine_seed.t_links,
            fine_seed.s_links,
            fine_seed.seconds
        )),
    );
    default_rays(su, quick, r, table)
}

/// Gather rays of [`default_rays`]: the crate's default `N_g`.
const DEFAULT_RAYS: usize = 256;
/// Level-0 dropped share of the target row at [`DEFAULT_RAYS`] (ours, session 27;
/// the crate's default since session 29).
const SHARE_AT_DEFAULT_RAYS: f64 = wavelux::meshless::config::DEFAULT_MAX_DROPPED_SHARE;

/// The error target at the crate's default gather rays (the runs above use fewer, for
/// time): the seed's criteria alone, the bound [`SHARE`], and the bound
/// [`SHARE_AT_DEFAULT_RAYS`], which is judged against issue 15's 5 %. With fewer rays
/// the gather noise of eq. (16) keeps links the criteria would drop (and with the
/// bound overshoots the energy); with 256 the seed's criteria drop most of the
/// indirect energy at this ε and the bound restores it.
fn default_rays(
    su: &Setup<'_>,
    quick: bool,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<()> {
    let s = su.s;
    let base = MeshlessConfig {
        gather_rays: DEFAULT_RAYS,
        ..config(s, s.r_eps, 0.005)
    };
    let mut runs = Vec::new();
    for (share, note) in [
        (None, ""),
        (Some(SHARE), ""),
        (Some(SHARE_AT_DEFAULT_RAYS), " (the crate's default)"),
    ] {
        let cfg = MeshlessConfig {
            max_dropped_share: share,
            ..base.clone()
        };
        let (run, _) = su.run(&cfg)?;
        let label = share.map_or("the seed's criteria".to_string(), |d| {
            format!("level-0 dropped share ≤ {d}{note}")
        });
        table.push(run_row(
            format!(
                "R_coarse = {} m, ε = 0.005, {DEFAULT_RAYS} gather rays, {label}",
                s.r_eps
            ),
            &run,
        ));
        runs.push((label, run));
    }
    let (last, rest) = runs.split_last().expect("three runs");
    r.rows.push(
        Row::new(
            format!(
                "indirect relative L1 vs path tracer, Cornell box, ε = 0.005, {DEFAULT_RAYS} \
                 gather rays, {}",
                last.0
            ),
            Some(0.05),
            last.1.l1,
            "",
            issue_target(quick),
        )
        .comment(format!(
            "issue 15's target at the crate's default gather rays with the bound (ours; \
             the share was chosen in session 27 after probing 0.1 and 0.05 at these rays \
             with `--example meshless_eps_probe`; info in the quick run); energy {:.3}, {} \
             links in T; same rays: {}",
            last.1.energy,
            last.1.t_links,
            rest.iter()
                .map(|(l, q)| format!(
                    "{l} {:.2} % (energy {:.3}, {} links in T)",
                    100.0 * q.l1,
                    q.energy,
                    q.t_links
                ))
                .collect::<Vec<_>>()
                .join("; ")
        )),
    );
    Ok(())
}

/// One precomputation, relit by the scene's own lighting, measured at the points.
#[derive(Clone)]
struct Run {
    receivers: usize,
    senders: usize,
    t_links: usize,
    s_links: usize,
    seconds: f64,
    refine_ms: f64,
    computed: usize,
    l1: f64,
    energy: f64,
    /// Ours at the points.
    ours: Vec<[f64; 3]>,
}

/// The inputs every run shares: the scene, its surfaces, the mode's sizes, the camera
/// points and their path-traced indirect reference.
struct Setup<'a> {
    scene: &'a Scene,
    query: &'a SceneSurfaces,
    s: &'a Sizes,
    points: &'a [ViewPoint],
    reference: &'a [([f64; 3], [f64; 3])],
}

impl Setup<'_> {
    /// One precomputation with `cfg`, relit by the scene's own lighting and measured
    /// at the points.
    fn run(&self, cfg: &MeshlessConfig) -> anyhow::Result<(Run, Precomputed)> {
        let (scene, query) = (self.scene, self.query);
        let (pre, time) = precompute(scene, cfg)?;
        let seconds = time.total.wall;
        let relighter = Relighter::new(&pre, CpuBackend)?;
        let direct = scene_direct(scene, query, self.s.emitter_samples, 1);
        let ind = relighter.relight_with(query, &direct)?;
        let ours = at_points(&ind, self.points);
        let (l1, _) = relative_l1(&ours, self.reference);
        let run = Run {
            receivers: functions(&pre),
            senders: pre.senders(),
            t_links: pre.t.nnz(),
            s_links: pre.s.nnz(),
            seconds,
            refine_ms: pre.stats.refine_ms,
            computed: pre.stats.refine.levels.iter().map(|l| l.computed).sum(),
            l1,
            energy: energy_ratio(&ours, self.reference),
            ours,
        };
        drop(ind);
        Ok((run, pre))
    }
}

/// Issue 15's 5 % target on the Cornell box, judged in the full run only: the quick
/// run's reference (noise floor ≈ 3.2 %) is most of the budget, so there it is info.
fn issue_target(quick: bool) -> Tolerance {
    if quick {
        Tolerance::Info
    } else {
        Tolerance::AtMost(0.05)
    }
}

fn run_row(label: String, r: &Run) -> Vec<String> {
    vec![
        label,
        r.receivers.to_string(),
        r.senders.to_string(),
        r.t_links.to_string(),
        r.s_links.to_string(),
        format!("{:.2}", r.seconds),
        format!("{:.2} %", 100.0 * r.l1),
        format!("{:.3}", r.energy),
    ]
}

const RUN_HEADERS: [&str; 8] = [
    "run",
    "receivers",
    "senders",
    "links T",
    "links S",
    "precompute (s)",
    "indirect rel. L1",
    "energy ours/ref",
];

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let s = if ctx.quick { &QUICK } else { &FULL };
    let mut r = Report::default();
    let scene = scene("cornell-box")?;
    let query = SceneSurfaces::new(&scene)?;
    let tracer = PathTracer::new(&scene)?;
    let points = super::meshless_common::visible_points(&scene, &query, s.points)?;
    let reference = reference_indirect(&tracer, &points, s.paths, 7)?;
    let (_, floor) = relative_l1(
        &reference.iter().map(|(m, _)| *m).collect::<Vec<_>>(),
        &reference,
    );
    describe(&mut r, s, points.len(), floor);
    let su = Setup {
        scene: &scene,
        query: &query,
        s,
        points: &points,
        reference: &reference,
    };
    let mut table = Vec::new();
    let sweep = point_sweep(&su, &mut r, &mut table)?;
    let eps_runs = eps_sweep(&su, &sweep, floor, &mut r, &mut table)?;
    what_bounds_the_target(&su, &eps_runs[4], &mut r, &mut table)?;
    share_sweep(&su, &sweep, ctx.quick, &mut r, &mut table)?;
    edge_band_rows(&su, &eps_runs[4], &mut r);
    r.rows.push(
        Row::new(
            "indirect relative L1 vs path tracer, Cornell box, ε = 0.0025",
            None,
            eps_runs[5].l1,
            "",
            Tolerance::Info,
        )
        .comment(format!(
            "{} links in T, precompute {:.1} s (ε = 0.005: {}, {:.1} s)",
            eps_runs[5].t_links, eps_runs[5].seconds, eps_runs[4].t_links, eps_runs[4].seconds
        )),
    );
    paper_bounces(&su, &mut r, &mut table)?;
    dense_comparison(&su, &mut r, &mut table)?;
    r.tables.push(Table {
        title: "Runs (one precomputation each; error against the path tracer)".into(),
        headers: RUN_HEADERS.iter().map(|h| h.to_string()).collect(),
        rows: table,
    });
    figures(ctx, s, &sweep, &eps_runs, &mut r)?;
    Ok(r)
}

/// The report's parameters and its "paper did" / "we did" text.
fn describe(r: &mut Report, s: &Sizes, points: usize, floor: f64) {
    r.param(
        "scene",
        "builtin:cornell-box (area light; emitters sampled by NEE)",
    );
    r.param(
        "levels",
        format!(
            "{} receiver / 2 sender levels, {} gather rays, {} emitter samples per sender, 4 bounces",
            s.levels, s.gather_rays, s.emitter_samples
        ),
    );
    r.param(
        "reference",
        format!(
            "path-traced indirect irradiance at {} camera points, {} walks each (noise floor {:.2} %)",
            points,
            s.paths,
            100.0 * floor
        ),
    );
    r.paper_did = "Meshless §4.2 precomputes with 6 receiver and 3 sender levels at ε = 0.025 \
        and reports (Table 1) that only 0.032–0.052 % of the potential sender × receiver \
        links are computed; against the non-hierarchical method of Kristensen et al. it \
        claims two orders of magnitude faster precomputation on the Sponza Atrium. It \
        gives no scaling curve and no error against a reference."
        .into();
    r.we_did = format!(
        "Cornell box (the issue's error target scene), lit by its own area light. Every \
        run precomputes T and S = Σ_{{b≤8}} S_b (8 bounces, ours: the reference has all \
        of them; the ablation rows show the paper's 4) with the bounce products \
        thresholded at ε/100 (ours; the crate's default is ε/10), relights with the light's direct \
        irradiance at the sender points (NEE), and compares the indirect irradiance n·i \
        at {} points seen by the camera with the independent path tracer's \
        indirect-only estimate ({} walks per point; the reference's own noise floor, \
        {:.2} %, is included in every error). Point sweep: R_coarse ∈ {:?} m at ε = 0.005; \
        ε sweep at R_coarse = {} m; dense comparison: a one-level basis at the finest \
        spacing of a {}-level hierarchy, ε = 0 (every link kept), one bounce, against \
        the hierarchy at ε = 0.005, one bounce. What bounds the error target (ours): the \
        same configuration with a second seed (point placement and gather strata), and \
        its error split by the points' distance to the box's other faces (walls, floor, \
        ceiling, open front). The point sweep is repeated with each level-0 receiver's \
        links dropped by the criteria bounded to {SHARE} of its gathered mass \
        (`max_dropped_share`, ours: the seed's uniform ε drops more of a finer level 0's \
        links, each ∝ R_coarse²). The error target is also run at the crate's default \
        {DEFAULT_RAYS} gather rays: the seed's criteria, the bound {SHARE} and the bound \
        {SHARE_AT_DEFAULT_RAYS} (judged; the crate's default since session 29). Every \
        other run uses the seed's link criteria alone (its label names a share where it \
        does not), so those rows measure the seed's criteria. Reduced sizes (levels, gather rays, \
        points) are ours, for the shared 2-core machine; the quick run is smaller still.",
        points,
        s.paths,
        100.0 * floor,
        s.r_sweep,
        s.r_eps,
        s.dense_levels
    );
}

/// The slope of `y` against the receivers over the point sweep's runs.
fn receiver_slope(sweep: &[Run], y: impl Fn(&Run) -> f64) -> f64 {
    log_slope(
        &sweep
            .iter()
            .map(|q| (q.receivers as f64, y(q)))
            .collect::<Vec<_>>(),
    )
}

/// The point sweep (`R_coarse` at ε = 0.005) and its growth and error rows; its
/// runs, coarsest first.
fn point_sweep(
    su: &Setup<'_>,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<Vec<Run>> {
    let s = su.s;
    let mut sweep = Vec::new();
    for &rc in &s.r_sweep {
        let (run, _) = su.run(&config(s, rc, 0.005))?;
        table.push(run_row(format!("R_coarse = {rc} m, ε = 0.005"), &run));
        sweep.push(run);
    }
    let links_exp = receiver_slope(&sweep, |q| q.s_links as f64);
    let t_exp = receiver_slope(&sweep, |q| q.t_links as f64);
    let time_exp = receiver_slope(&sweep, |q| q.refine_ms);
    let work_exp = receiver_slope(&sweep, |q| q.computed as f64);
    let err_exp = receiver_slope(&sweep, |q| q.l1);
    r.rows.push(
        Row::new(
            "exponent of links in T against receivers (R_coarse sweep, ε = 0.005)",
            Some(1.0),
            t_exp,
            "",
            // Issue 15 asks for an exponent ≈ 1 against a flat method's 2. The band
            // admits O(n log n) (local exponent 1 + 1/ln n ≈ 1.15 at the sweep's few
            // hundred to few thousand receivers) and stays well short of half the way
            // to 2 (1.5): a judgment between those two, not a measured accuracy.
            Tolerance::Absolute(0.35),
        )
        .comment("issue 15: links follow the receivers, not their square"),
    );
    r.rows.push(Row::new(
        "exponent of links in S against receivers",
        Some(1.0),
        links_exp,
        "",
        Tolerance::Info,
    ));
    r.rows.push(
        Row::new(
            "exponent of refinement work (links computed) against receivers",
            Some(1.0),
            work_exp,
            "",
            Tolerance::Absolute(0.35),
        )
        .comment("the refinement's cost in links evaluated (deterministic)"),
    );
    r.rows.push(
        Row::new(
            "exponent of refinement wall time against receivers",
            Some(1.0),
            time_exp,
            "",
            Tolerance::Info,
        )
        .comment(
            "wall time on the shared machine: the same configuration measured 1.07, 1.27 \
             and 1.94 in three quick runs of session 21, so it is context, not a gate",
        ),
    );
    r.rows.push(Row::new(
        "exponent of the indirect error against receivers (slope of the error vs points)",
        None,
        err_exp,
        "",
        Tolerance::Info,
    ));
    r.rows.push(
        Row::new(
            "indirect error at the finest / coarsest R_coarse",
            None,
            sweep[2].l1 / sweep[0].l1,
            "",
            Tolerance::AtMost(1.0),
        )
        .comment("the error falls as R_coarse shrinks"),
    );
    Ok(sweep)
}

/// The ε sweep at `R_coarse = r_eps` and its rows, with issue 15's error target at
/// ε = 0.005; its runs in the order of [`EPS`]. The point sweep's finest run is the
/// same configuration at ε = 0.005 when `r_eps` is its `R_coarse`: the
/// precomputation is deterministic, so it is reused.
fn eps_sweep(
    su: &Setup<'_>,
    sweep: &[Run],
    floor: f64,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<Vec<Run>> {
    let s = su.s;
    let mut eps_runs = Vec::new();
    for &eps in &EPS {
        let run = if eps == 0.005 && s.r_eps == s.r_sweep[2] {
            sweep[2].clone()
        } else {
            su.run(&config(s, s.r_eps, eps))?.0
        };
        table.push(run_row(
            format!("R_coarse = {} m, ε = {eps}", s.r_eps),
            &run,
        ));
        eps_runs.push(run);
    }
    let eps_exp = log_slope(
        &EPS.iter()
            .zip(&eps_runs)
            .map(|(&e, q)| (e, q.l1))
            .collect::<Vec<_>>(),
    );
    r.rows.push(Row::new(
        "exponent of the indirect error against ε",
        None,
        eps_exp,
        "",
        Tolerance::Info,
    ));
    r.rows.push(
        Row::new(
            "indirect error at ε = 0.005 / at ε = 0.1",
            None,
            eps_runs[4].l1 / eps_runs[0].l1,
            "",
            Tolerance::AtMost(1.0),
        )
        .comment("the error falls as ε shrinks"),
    );
    r.rows.push(Row::new(
        "indirect energy kept at ε = 0.025 (ours / reference)",
        None,
        eps_runs[2].energy,
        "",
        Tolerance::Info,
    ));
    let target = Row::new(
        "indirect relative L1 vs path tracer, Cornell box, ε = 0.005",
        Some(0.05),
        eps_runs[4].l1,
        "",
        Tolerance::AtMost(0.05),
    )
    .comment(format!(
        "reference noise floor {:.2} %; {} receivers",
        100.0 * floor,
        eps_runs[4].receivers
    ));
    r.rows.push(target);
    Ok(eps_runs)
}

/// What bounds the error target at ε = 0.005 (`target`, the ε sweep's run there): the
/// same configuration with another seed (point placement and gather strata), and
/// which links the threshold truncates.
fn what_bounds_the_target(
    su: &Setup<'_>,
    target: &Run,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<()> {
    let s = su.s;
    let cfg = MeshlessConfig {
        seed: 2,
        ..config(s, s.r_eps, 0.005)
    };
    let (run, _) = su.run(&cfg)?;
    r.rows.push(
        Row::new(
            "indirect relative L1 vs path tracer, ε = 0.005, seed 2 (point placement, gather strata)",
            None,
            run.l1,
            "",
            Tolerance::Info,
        )
        .comment(format!(
            "energy {:.3}; {} receivers; the two seeds' solutions differ by {:.2} % (relative L1)",
            run.energy,
            run.receivers,
            100.0 * relative_l1(&run.ours, &exact_ref(&target.ours)).0
        )),
    );
    table.push(run_row(
        format!("R_coarse = {} m, ε = 0.005, seed 2", s.r_eps),
        &run,
    ));
    // Which links the threshold truncates: the same run with the threshold scaled by
    // the sender's support area (ε/4^l on sender level l), and with level-0 senders
    // only. If the finer senders' links carried the lost energy, the first would
    // recover it and the second would lose more.
    for (label, cfg) in [
        (
            "ε = 0.005 scaled with the sender's area (ε/4^l)",
            MeshlessConfig {
                threshold: LinkThreshold::SenderArea,
                ..config(s, s.r_eps, 0.005)
            },
        ),
        (
            "ε = 0.005, level-0 senders only",
            MeshlessConfig {
                sender_levels: 1,
                ..config(s, s.r_eps, 0.005)
            },
        ),
    ] {
        let (run, _) = su.run(&cfg)?;
        r.rows.push(
            Row::new(
                format!("indirect relative L1 vs path tracer, {label}"),
                None,
                run.l1,
                "",
                Tolerance::Info,
            )
            .comment(format!(
                "energy {:.3}, {} links in T (uniform ε = 0.005, two sender levels: {:.3}, {})",
                run.energy, run.t_links, target.energy, target.t_links
            )),
        );
        table.push(run_row(format!("R_coarse = {} m, {label}", s.r_eps), &run));
    }
    Ok(())
}

/// The error at ε = 0.005 (`target`) split by the points' distance to the box's
/// other faces ([`EDGE_BANDS`]).
fn edge_band_rows(su: &Setup<'_>, target: &Run, r: &mut Report) {
    let (points, reference) = (su.points, su.reference);
    let (lo, hi) = su.query.bounds();
    for (band, a, b) in EDGE_BANDS {
        let keep: Vec<usize> = (0..points.len())
            .filter(|&k| {
                let d = face_distance(points[k], lo, hi);
                d > a && d <= b
            })
            .collect();
        let ours: Vec<[f64; 3]> = keep.iter().map(|&k| target.ours[k]).collect();
        let refs: Vec<([f64; 3], [f64; 3])> = keep.iter().map(|&k| reference[k]).collect();
        let (l1, fl) = relative_l1(&ours, &refs);
        r.rows.push(
            Row::new(
                format!("indirect relative L1, ε = 0.005, points {band}"),
                None,
                l1,
                "",
                Tolerance::Info,
            )
            .comment(format!(
                "{} points; ours / reference energy {:.3}; reference noise floor there {:.2} %",
                keep.len(),
                energy_ratio(&ours, &refs),
                100.0 * fl
            )),
        );
    }
}

/// Where the energy goes at ε = 0.005: the paper's four bounces with the crate's
/// default bounce threshold.
fn paper_bounces(
    su: &Setup<'_>,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<()> {
    let s = su.s;
    let label =
        "ε = 0.005, 4 bounces, bounce threshold ε/10 (the crate's defaults), the seed's criteria";
    let cfg = MeshlessConfig {
        bounces: 4,
        bounce_epsilon: None,
        ..config(s, s.r_eps, 0.005)
    };
    let (run, _) = su.run(&cfg)?;
    r.rows.push(Row::new(
        format!("indirect energy kept (ours / reference), {label}"),
        None,
        run.energy,
        "",
        Tolerance::Info,
    ));
    r.rows.push(Row::new(
        format!("indirect relative L1 vs path tracer, {label}"),
        None,
        run.l1,
        "",
        Tolerance::Info,
    ));
    table.push(run_row(format!("R_coarse = {} m, {label}", s.r_eps), &run));
    Ok(())
}

/// A dense one-level transfer against the hierarchy at equal finest points: time,
/// links, and the two one-bounce solutions against each other.
fn dense_comparison(
    su: &Setup<'_>,
    r: &mut Report,
    table: &mut Vec<Vec<String>>,
) -> anyhow::Result<()> {
    let (s, scene, query, points) = (su.s, su.scene, su.query, su.points);
    let hier_cfg = MeshlessConfig {
        receiver_levels: s.dense_levels,
        sender_levels: s.dense_levels.min(2),
        bounces: 1,
        ..config(s, s.dense_r, 0.005)
    };
    let finest = s.dense_r / f64::powi(2.0, s.dense_levels as i32 - 1);
    let dense_cfg = MeshlessConfig {
        receiver_levels: 1,
        sender_levels: 1,
        bounces: 1,
        c_coarse: hier_cfg.support_factor(s.dense_levels - 1),
        ..config(s, finest, 0.0)
    };
    let (hier, hier_pre) = su.run(&hier_cfg)?;
    let (dense, dense_pre) = su.run(&dense_cfg)?;
    table.push(run_row(
        format!(
            "hierarchy, {} levels, R_coarse = {} m, ε = 0.005, 1 bounce",
            s.dense_levels, s.dense_r
        ),
        &hier,
    ));
    table.push(run_row(
        format!("dense one level, R = {finest} m, ε = 0, 1 bounce"),
        &dense,
    ));
    // The two one-bounce solutions against each other.
    let direct = scene_direct(scene, query, s.emitter_samples, 1);
    let hi = Relighter::new(&hier_pre, CpuBackend)?.relight_with(query, &direct)?;
    let de = Relighter::new(&dense_pre, CpuBackend)?.relight_with(query, &direct)?;
    let hi_v = at_points(&hi, points);
    let (hd, _) = relative_l1(&hi_v, &exact_ref(&at_points(&de, points)));
    r.rows.push(
        Row::new(
            "dense / hierarchical refinement time at equal finest points",
            Some(100.0),
            dense.refine_ms / hier.refine_ms,
            "",
            Tolerance::AtLeast(1.0),
        )
        .comment(format!(
            "paper: ~100× over Kristensen et al. at 192k functions; here {} dense points \
             against {} hierarchical receivers; the hierarchy must win at equal points",
            dense.receivers, hier.receivers
        )),
    );
    r.rows.push(Row::new(
        "dense / hierarchical links (T)",
        None,
        dense.t_links as f64 / hier.t_links as f64,
        "",
        Tolerance::AtLeast(1.0),
    ));
    r.rows.push(
        Row::new(
            "one-bounce indirect, hierarchy vs dense, relative L1",
            None,
            hd,
            "",
            // Derived: the dense one-level transfer at the hierarchy's finest points is
            // the operator without the threshold's truncation, and issue 15 states the
            // method's accuracy at ε = 0.005 as ≤ 5 % (Cornell box, against the path
            // tracer, every error included); the truncation alone can then not exceed
            // it. (Was 10 %, a judgment.)
            Tolerance::AtMost(0.05),
        )
        .comment(
            "the hierarchy at ε = 0.005 reproduces the dense transfer within issue 15's \
             5 % at that ε",
        ),
    );
    Ok(())
}

/// The error-against-ε and links-against-receivers figures.
fn figures(
    ctx: &Ctx,
    s: &Sizes,
    sweep: &[Run],
    eps_runs: &[Run],
    r: &mut Report,
) -> anyhow::Result<()> {
    let path = ctx.figure_path("error-vs-eps.svg");
    xy_plot(
        &path,
        "Cornell box: indirect error against ε",
        &Axis::log("ε"),
        &Axis::log("relative L1 of n·i"),
        &[Series::new(
            format!("R_coarse = {} m", s.r_eps),
            EPS.iter().zip(eps_runs).map(|(&e, q)| (e, q.l1)).collect(),
            Style::LinePoints,
        )],
    )?;
    r.figures.push(Figure {
        path,
        caption: "Indirect relative L1 against the path tracer as ε shrinks".into(),
    });
    let path = ctx.figure_path("links-vs-receivers.svg");
    xy_plot(
        &path,
        "Cornell box: links and error against receivers (ε = 0.005)",
        &Axis::log("receivers"),
        &Axis::log("links"),
        &[
            Series::new(
                "links in T",
                sweep
                    .iter()
                    .map(|q| (q.receivers as f64, q.t_links as f64))
                    .collect(),
                Style::LinePoints,
            ),
            Series::new(
                "links in S",
                sweep
                    .iter()
                    .map(|q| (q.receivers as f64, q.s_links as f64))
                    .collect(),
                Style::LinePoints,
            ),
        ],
    )?;
    r.figures.push(Figure {
        path,
        caption: "Links against receivers over the R_coarse sweep".into(),
    });
    Ok(())
}
