//! Meshless §4.2, Table 1: direct-to-indirect precomputation statistics on the atrium
//! (our stand-in for Sponza) with level 0 tuned to the paper's 339 functions.
//!
//! Paper (Q6600, Sponza, 66k triangles, 6/3 levels, ε = 0.025, four bounces): 973k
//! links (0.032 % of senders × receivers), 92M visibility rays, 339 level-0 and 192k
//! functions, adaptive refinement 18:18, bounces 7:56, total 26:14 (m:s), 77.4 MB.
//! Great Hall (2.3M triangles, 177k functions): total 28:56. The derived quantities
//! compared here: links per receiver 973k/192k = 5.07, link fraction 3.2e-4, rays per
//! function 92M/192k = 479, refinement share 18:18/26:14 = 0.698, bytes per link
//! 77.4 MB/973k = 79.5, and the time ratio 28:56/26:14 = 1.10 of a 35× larger mesh
//! (cost follows the functions, not the triangles).
//!
//! Tolerances (issue 13 §1: derived from a stated accuracy, or why not), registered
//! before the session-27 run:
//! - level-0 functions `±20 %` of 339: **derived** from issue 15's registration
//!   ("level 0 tuned to 339 ± 20 %"); the tuner stops within 5 %.
//! - precompute CPU time `≤ 240 s` with `≥ 50k` receivers: **derived** from issue 15's
//!   target "< 2 min on 2 cores" (both cores busy for 120 s: 240 CPU s).
//! - frame CPU time (direct + pull-push + `S·e`) `≤ 20 ms`: **derived** from issue 15's
//!   target "< 20 ms per frame on the CPU", compared in the CPU time of the frame's
//!   phases ([`super::meshless_common::relight_timed`]; one rayon thread in the
//!   committed runs, so it is the time of one core). Until session 26 this row compared
//!   wall time on the shared machine, which measured its load.
//! - functions (all levels) within a factor 2 of 192k: **not derived**. With level 0
//!   fixed, the total follows how much of the scene's area lies in features finer than
//!   each level's spacing (each level holds at most 4× the previous one on surfaces
//!   larger than its spacing: `339·(4⁶ − 1)/3 ≈ 463k` at most; the paper's 192k is an
//!   average growth of 3.55 per level), which the paper does not give for Sponza and
//!   our atrium only approximates; a factor 2 is a per-level growth within
//!   `2^(1/5) ≈ 1.15` of the paper's.
//! - links in T per receiver, link fraction, rays per function, each within a factor
//!   3: **not derived**. They depend on the link norm's units (the seed's eq. (16) omits
//!   the Lambertian `1/π`, so its `ε` may be π times ours), on the senders' count, and
//!   on the gather rays `N_g`, which the paper does not state (ours: 256, so rays per
//!   function is `N_g` times the share of receivers queued, plus placement); a factor
//!   3 is our judgment of "the same order".
//! - refinement share `±0.25` of the paper's 0.70, in CPU time: **not derived** (the
//!   share follows the relative cost of the refinement and the bounce products, which
//!   follows the links in S per receiver; our phases are read as CPU time at the
//!   crate's progress calls).
//! - bytes per link within a factor 2: **not derived** (the paper's storage precision
//!   and what its 77.4 MB holds are not stated).
//! - precompute time atrium-xl / atrium within a factor 1.5 of the paper's 1.10: **not
//!   derived**. The claim is that the cost follows the functions, not the triangles: a
//!   cost following the triangles would give ≈ 14× here; ray casting in a BVH grows
//!   about with the log of the primitives (≈ 1.24× from 52k to 718k), which this
//!   factor admits.

use super::meshless_common::{
    FrameCpu, PrecomputeTime, functions, precompute, relight_timed, scene,
};
use crate::report::{Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::meshless::relight::default_viewpoint;
use wavelux::meshless::{
    CpuBackend, FrameTimes, LinkThreshold, MeshlessConfig, Precomputed, Relighter, SceneSurfaces,
    SurfaceQuery, place_points,
};
use wavelux::param::glam::DVec3;
use wavelux::scene::Scene;

/// Problem sizes of one mode.
struct Sizes {
    small: &'static str,
    large: &'static str,
    levels: usize,
    senders: usize,
    gather_rays: usize,
}

const QUICK: Sizes = Sizes {
    small: "atrium-s",
    large: "atrium",
    levels: 3,
    senders: 2,
    gather_rays: 64,
};

/// The full run at the paper's 6 receiver / 3 sender levels, on the atrium and on its
/// ≈ 1M-triangle version.
const FULL: Sizes = Sizes {
    small: "atrium",
    large: "atrium-xl",
    levels: 6,
    senders: 3,
    gather_rays: 256,
};

/// Issue 15's precompute target: `atrium` with at least 50k receivers in under 2 min
/// on 2 cores, compared as CPU time: 2 cores × 120 s (ours: the wall time of the shared
/// machine measures its load).
const PRECOMPUTE_TARGET_CPU_S: f64 = 240.0;
/// Its receivers.
const PRECOMPUTE_TARGET_FUNCTIONS: f64 = 50e3;
/// Issue 15's frame target: direct, pull-push and `S·e` under 20 ms on the CPU (ms).
const FRAME_TARGET_MS: f64 = 20.0;

/// The paper's level-0 count (Sponza).
const LEVEL0: f64 = 339.0;

/// `R_coarse` whose level 0 holds about [`LEVEL0`] points: points ∝ R⁻², three
/// secant steps from 5 % of the diagonal (ours).
fn tune_r(
    q: &SceneSurfaces,
    viewpoint: DVec3,
    cfg: &MeshlessConfig,
) -> anyhow::Result<(f64, usize)> {
    let (lo, hi) = q.bounds();
    let diag = (hi - lo).length();
    let mut r = 0.05 * diag;
    let mut n = 0;
    for _ in 0..4 {
        let one = MeshlessConfig {
            receiver_levels: 1,
            sender_levels: 1,
            r_coarse: Some(r),
            ..cfg.clone()
        };
        n = place_points(q, &one, viewpoint, diag, &|_, _| {})?.levels[0].len();
        if (n as f64 / LEVEL0 - 1.0).abs() < 0.05 {
            break;
        }
        r *= (n as f64 / LEVEL0).sqrt();
    }
    Ok((r, n))
}

fn secs(ms: f64) -> String {
    let s = ms / 1e3;
    format!("{}:{:04.1}", (s / 60.0).floor() as u64, s % 60.0)
}

/// Three frames of `pre` lit by the scene's own lights (the runtime phases of the
/// frame target), in CPU time, with the crate's wall-time split of each.
type Frames = Vec<(FrameCpu, FrameTimes)>;

fn frames(pre: &Precomputed, q: &SceneSurfaces, sc: &Scene) -> anyhow::Result<Frames> {
    let relighter = Relighter::new(pre, CpuBackend)?;
    (0..3)
        .map(|_| {
            let (ind, cpu) = relight_timed(pre, &relighter, q, &sc.lights)?;
            Ok((cpu, ind.times))
        })
        .collect()
}

/// Issue 15's two targets on `name`'s precomputation `pre` (its phases, its frames),
/// `criteria` naming the link criteria in the rows' labels: the precompute CPU time
/// (≤ 240 s with ≥ 50k receivers) and the fastest frame's CPU time (≤ 20 ms; the first
/// frame pays for first touches of memory).
fn target_rows(
    r: &mut Report,
    name: &str,
    criteria: &str,
    pre: &Precomputed,
    phases: &PrecomputeTime,
    frames: &Frames,
) {
    let pre_t = phases.total;
    let f = functions(pre) as f64;
    let Some(&(frame, frame_wall)) = frames
        .iter()
        .min_by(|a, b| a.0.total_ms().total_cmp(&b.0.total_ms()))
    else {
        return;
    };
    let big_enough = f >= PRECOMPUTE_TARGET_FUNCTIONS;
    let gate = |t: Tolerance| if big_enough { t } else { Tolerance::Info };
    r.rows.push(
        Row::new(
            format!("precompute CPU time of {name}, {criteria} (s)"),
            None,
            pre_t.cpu_or_wall(),
            "s",
            gate(Tolerance::AtMost(PRECOMPUTE_TARGET_CPU_S)),
        )
        .comment(format!(
            "issue 15's target: < 2 min on 2 cores (≤ {PRECOMPUTE_TARGET_CPU_S} CPU s) with \
             >= {PRECOMPUTE_TARGET_FUNCTIONS} receivers ({f} here{}); {} links in T, {} in \
             S; wall {:.1} s on the shared machine{}",
            if big_enough {
                ""
            } else {
                ": too few, context only"
            },
            pre.t.nnz(),
            pre.s.nnz(),
            pre_t.wall,
            if pre_t.cpu.is_none() {
                " (no CPU clock: wall compared)"
            } else {
                ""
            }
        )),
    );
    r.rows.push(
        Row::new(
            format!("frame CPU time on {name}, {criteria}: direct + pull-push + S·e (ms)"),
            None,
            frame.total_ms(),
            "ms",
            gate(Tolerance::AtMost(FRAME_TARGET_MS)),
        )
        .comment(format!(
            "issue 15's target: < {FRAME_TARGET_MS} ms on the CPU; the scene's spot, fastest \
             of three frames in CPU time ({}): direct {:.1} ms, pull-push + S·e {:.1} ms \
             ({} of {} senders active); wall of the same frame: pull-push {:.1} ms, S·e \
             {:.1} ms",
            frames
                .iter()
                .map(|f| format!("{:.1}", f.0.total_ms()))
                .collect::<Vec<_>>()
                .join(", "),
            frame.direct_ms,
            frame.transport_ms,
            frame_wall.active_senders,
            pre.senders(),
            frame_wall.pull_push_ms,
            frame_wall.transport_ms,
        )),
    );
}

/// The precomputation of `name` at `cfg` with the crate's default
/// `max_dropped_share` (ours, since session 29) instead of the paper's criteria alone:
/// issue 15's targets at the crate's defaults, and its links per receiver (info: the
/// bound is not the paper's method).
fn default_share_run(
    r: &mut Report,
    name: &str,
    sc: &Scene,
    q: &SceneSurfaces,
    cfg: &MeshlessConfig,
) -> anyhow::Result<(Precomputed, PrecomputeTime)> {
    let share = MeshlessConfig::default().max_dropped_share;
    let cfg = MeshlessConfig {
        max_dropped_share: share,
        ..cfg.clone()
    };
    let (pre, phases) = precompute(sc, &cfg)?;
    let criteria = format!(
        "the crate's default level-0 dropped share ≤ {}",
        share.map_or("none".into(), |d| d.to_string())
    );
    let frames = frames(&pre, q, sc)?;
    target_rows(r, name, &criteria, &pre, &phases, &frames);
    r.rows.push(
        Row::new(
            format!("links in T per receiver, {criteria}"),
            Some(973e3 / 192e3),
            pre.t.nnz() as f64 / functions(&pre) as f64,
            "",
            Tolerance::Info,
        )
        .comment(format!(
            "{} links in T, {} in S; CPU: placement {}, refinement {}, bounces {} (m:s)",
            pre.t.nnz(),
            pre.s.nnz(),
            secs(1e3 * phases.placement),
            secs(1e3 * phases.refine),
            secs(1e3 * phases.bounces),
        )),
    );
    Ok((pre, phases))
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let s = if ctx.quick { &QUICK } else { &FULL };
    let mut r = Report::default();
    let small = scene(s.small)?;
    let large = scene(s.large)?;
    let q_small = SceneSurfaces::new(&small)?;
    let base = MeshlessConfig {
        receiver_levels: s.levels,
        sender_levels: s.senders,
        gather_rays: s.gather_rays,
        epsilon: 0.025,
        threshold: LinkThreshold::Uniform,
        // The paper's Fig. 5 criteria alone (the crate's default bounds the level-0
        // dropped share since session 29: [`default_share_run`]).
        max_dropped_share: None,
        bounces: 4,
        ..MeshlessConfig::default()
    };
    let viewpoint = default_viewpoint(&small, q_small.bounds());
    let (rc, level0) = tune_r(&q_small, viewpoint, &base)?;
    let cfg = MeshlessConfig {
        r_coarse: Some(rc),
        ..base
    };
    let (pre, phases) = precompute(&small, &cfg)?;
    let pre_t = phases.total;
    let frames = frames(&pre, &q_small, &small)?;
    let (pre_large, large_phases) = precompute(&large, &cfg)?;
    let pre_large_t = large_phases.total;
    // Mesh triangles (a parallelogram of a mesh counts as its two triangles) and the
    // primitives the `Accel` holds after merging triangle pairs into parallelograms.
    let tris = |sc: &wavelux::scene::Scene| -> (usize, usize) {
        let t = sc
            .surfaces
            .iter()
            .map(|x| match &x.shape {
                wavelux::scene::Shape::Mesh(m) => m.triangle_count(),
                _ => 0,
            })
            .sum();
        (t, sc.primitives(&sc.name).map(|p| p.len()).unwrap_or(0))
    };
    let (tris_small, prims_small) = tris(&small);
    let (tris_large, prims_large) = tris(&large);
    r.param(
        "scenes",
        format!(
            "builtin:{} ({tris_small} triangles, {prims_small} primitives) and builtin:{} \
             ({tris_large} triangles, {prims_large} primitives), same shapes",
            s.small, s.large,
        ),
    );
    r.param(
        "configuration",
        format!(
            "{}/{} levels, ε = 0.025 (uniform, the paper's Fig. 5), 4 bounces, {} gather rays per receiver, R_coarse = {rc:.4} m \
             (level 0 tuned to {level0} points on {})",
            s.levels, s.senders, s.gather_rays, s.small
        ),
    );
    r.param(
        "timing",
        format!(
            "CPU time ({} rayon thread(s); the committed runs use one): the \
             precomputation's phases read at the crate's progress calls, each frame's \
             phases timed apart",
            rayon::current_num_threads()
        ),
    );
    r.param(
        "build",
        if cfg!(debug_assertions) {
            "dev profile (opt-level 1 for the workspace, dependencies optimised): times are \
             slower than a release build's"
        } else {
            "release"
        },
    );
    r.paper_did = "Table 1 lists, for Sponza (66k triangles), the Great Hall (2.3M) and the \
        Jade Palace (5.1M), the links kept, visibility rays, level-0 and total functions, \
        refinement, bounce and total times and memory, at 6 receiver / 3 sender levels, \
        ε = 0.025 and four bounces on a quad-core Q6600. Sponza: 973k links (0.032 %), \
        92M rays, 339 / 192k functions, 18:18 + 7:56 = 26:14, 77.4 MB."
        .into();
    r.we_did = format!(
        "Our atrium (same shapes as Sponza's courtyard: arcades, galleries, drapes, urns; \
         ours, Sponza is not redistributable) at the paper's settings{}, with R_coarse \
         tuned so that level 0 holds 339 ± 5 % points (three secant steps on R ∝ N^-1/2, \
         ours). The derived ratios are compared, since absolute times depend on the \
         machine. Links are those of T (computed by the refinement) and of S (after the \
         bounces); the paper's count is compared with T. Memory is the runtime basis \
         plus S in f64. The time ratio compares the same shapes at two mesh densities \
         with the same R_coarse (cost follows the functions), against the paper's Great \
         Hall / Sponza ratio.",
        if ctx.quick {
            format!(
                " except {} levels / {} senders and {} gather rays (quick run), on {} and {}",
                s.levels, s.senders, s.gather_rays, s.small, s.large
            )
        } else {
            format!(
                " ({}/{} levels, {} gather rays), on {} and {}",
                s.levels, s.senders, s.gather_rays, s.small, s.large
            )
        }
    );

    let st = &pre.stats;
    let f = functions(&pre) as f64;
    let quick_info = |t: Tolerance| if ctx.quick { Tolerance::Info } else { t };
    r.rows.push(Row::new(
        "level-0 functions",
        Some(LEVEL0),
        st.points_per_level[0] as f64,
        "",
        Tolerance::Relative(0.2),
    ));
    r.rows.push(
        Row::new(
            "functions (all levels)",
            Some(192e3),
            f,
            "",
            quick_info(Tolerance::Factor(2.0)),
        )
        .comment(format!("per level: {:?}", st.points_per_level)),
    );
    r.rows.push(
        Row::new(
            "links in T per receiver",
            Some(973e3 / 192e3),
            pre.t.nnz() as f64 / f,
            "",
            quick_info(Tolerance::Factor(3.0)),
        )
        .comment(format!("{} links in T, {} in S", pre.t.nnz(), pre.s.nnz())),
    );
    r.rows.push(
        Row::new(
            "link fraction (links in T / senders × receivers)",
            Some(3.2e-4),
            pre.t.nnz() as f64 / st.potential_links,
            "",
            quick_info(Tolerance::Factor(3.0)),
        )
        .comment(format!(
            "{} senders (paper: ≈ 15.8k implied by 0.032 %)",
            pre.senders()
        )),
    );
    r.rows.push(Row::new(
        "rays per function",
        Some(92e6 / 192e3),
        st.rays as f64 / f,
        "",
        quick_info(Tolerance::Factor(3.0)),
    ));
    r.rows.push(
        Row::new(
            "refinement share of the precomputation time",
            Some(1098.0 / 1574.0),
            phases.refine / pre_t.cpu_or_wall(),
            "",
            Tolerance::Absolute(0.25),
        )
        .comment(format!(
            "CPU: placement {}, refinement {}, bounces {}, total {} (m:s)",
            secs(1e3 * phases.placement),
            secs(1e3 * phases.refine),
            secs(1e3 * phases.bounces),
            secs(1e3 * pre_t.cpu_or_wall())
        )),
    );
    r.rows.push(
        Row::new(
            "bytes per link (basis + S, f64)",
            Some(77.4e6 / 973e3),
            pre.runtime_bytes() as f64 / pre.s.nnz() as f64,
            "B",
            Tolerance::Factor(2.0),
        )
        .comment(format!("{:.1} MB", pre.runtime_bytes() as f64 / 1e6)),
    );
    target_rows(
        &mut r,
        s.small,
        "the seed's criteria",
        &pre,
        &phases,
        &frames,
    );
    let fl = functions(&pre_large) as f64;
    r.rows.push(
        Row::new(
            format!("precompute CPU time {} / {}", s.large, s.small),
            Some(1736.0 / 1574.0),
            pre_large_t.cpu_or_wall() / pre_t.cpu_or_wall(),
            "",
            Tolerance::Factor(1.5),
        )
        .comment(format!(
            "{} / {} triangles; functions {} / {} (ratio {:.3}); CPU {:.1} / {:.1} s, wall \
             {:.1} / {:.1} s",
            tris_large,
            tris_small,
            fl,
            f,
            fl / f,
            pre_large_t.cpu_or_wall(),
            pre_t.cpu_or_wall(),
            pre_large_t.wall,
            pre_t.wall
        )),
    );

    let (pre_default, default_phases) = default_share_run(&mut r, s.small, &small, &q_small, &cfg)?;
    let mut rows = Vec::new();
    let default_name = format!("{} (the crate's default dropped share)", s.small);
    for (name, p, t) in [
        (s.small, &pre, &phases),
        (s.large, &pre_large, &large_phases),
        (default_name.as_str(), &pre_default, &default_phases),
    ] {
        let st = &p.stats;
        rows.push(vec![
            name.to_string(),
            format!(
                "{} ({:.4} %)",
                p.t.nnz(),
                100.0 * p.t.nnz() as f64 / st.potential_links
            ),
            p.s.nnz().to_string(),
            format!("{:.1}M", st.rays as f64 / 1e6),
            format!("{}/{}", p.config.receiver_levels, p.config.sender_levels),
            st.points_per_level[0].to_string(),
            functions(p).to_string(),
            secs(1e3 * t.refine),
            secs(1e3 * t.bounces),
            secs(1e3 * t.total.cpu_or_wall()),
            format!("{:.1} MB", p.runtime_bytes() as f64 / 1e6),
        ]);
    }
    rows.push(
        [
            "Sponza (paper)",
            "973k (0.032 %)",
            "—",
            "92M",
            "6/3",
            "339",
            "192k",
            "18:18",
            "7:56",
            "26:14",
            "77.4 MB",
        ]
        .iter()
        .map(|c| c.to_string())
        .collect(),
    );
    r.tables.push(Table {
        title: "Table 1 layout: ours (this run; times in CPU m:s) and the paper's Sponza row"
            .into(),
        headers: [
            "scene",
            "links T",
            "links S",
            "rays",
            "levels",
            "level 0",
            "functions",
            "refinement",
            "bounces",
            "total",
            "memory",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows,
    });
    let per_level: Vec<Vec<String>> = pre
        .stats
        .placement
        .levels
        .iter()
        .enumerate()
        .map(|(l, ls)| {
            let rl = pre.stats.refine.levels.get(l);
            vec![
                l.to_string(),
                format!("{:.4}", ls.spacing),
                ls.points.to_string(),
                ls.holes.to_string(),
                rl.map_or("—".into(), |x| x.processed.to_string()),
                rl.map_or("—".into(), |x| x.kept.to_string()),
            ]
        })
        .collect();
    r.tables.push(Table {
        title: format!("Per level on {} (placement and refinement)", s.small),
        headers: [
            "level",
            "R_l (m)",
            "points",
            "holes",
            "links processed",
            "links kept",
        ]
        .iter()
        .map(|h| h.to_string())
        .collect(),
        rows: per_level,
    });
    Ok(r)
}
