//! Speed vs accuracy of every method on scenes with and without closed forms (the
//! Cornell box, Ziegler's occluded pair and a curved-surface scene, VirtualMesh §6.2's
//! quadric teapot): error against the Monte Carlo reference (wavelux-render's path
//! tracer) against wall time, for the gathering wavelet solver (every basis, a sweep
//! of ε and levels), the linkless shooting solver on the Virtual Mesh (VirtualMesh §5;
//! bases, ε and levels) and the path tracer itself at increasing sample counts, all in
//! one run. Two error measures:
//! per-surface averages (area-weighted L1 over surfaces and channels, relative to the
//! reflected radiosity `B − E` so that exact emitters do not dilute it) and
//! per-pixel relative L1 of an image against a converged path-traced image.
//!
//! There is no paper number to match: the rows report, per scene and method, the
//! smallest wall time that reached 1 % and 0.1 % error (Info rows), so users can pick
//! their trade. The references' own noise floors are reported next to them: an error
//! below the floor is not resolved.

use std::time::Instant;

use crate::plot::{Axis, Series, Style, xy_plot};
use crate::report::{Figure, Report, Row, Table, Tolerance};
use crate::reproduce::Ctx;
use wavelux::render::{
    Image, PathTracer, ReferenceOptions, RenderOptions, SolutionField, View, auto_camera, render,
    scene_up,
};
use wavelux::scene::{Scene, builtin};
use wavelux::solver::shoot::{ShootConfig, shoot};
use wavelux::solver::{BasisKind, LinearMethod, Solution, SolverConfig, SolverError, solve};

/// One measured run.
struct Point {
    method: String,
    setting: String,
    time_surface: f64,
    err_surface: f64,
    time_image: f64,
    err_image: f64,
}

fn view_for(scene: &Scene, n: usize) -> anyhow::Result<View> {
    let cam = match scene.cameras.first() {
        Some(c) => c.clone(),
        None => auto_camera(scene, scene_up(scene, false))?,
    };
    Ok(View::new(&cam, n, n)?)
}

/// `Σ_s A_s Σ_c |B_sc − B̂_sc| / Σ_s A_s Σ_c |B̂_sc − E_sc|`: the L1 error of the
/// surface averages relative to the *reflected* radiosity (emitters' `E` is exact for
/// every method and would otherwise dominate the denominator).
fn surface_error(b: &[[f64; 3]], reference: &[[f64; 3]], areas: &[(f64, [f64; 3])]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for ((x, y), (a, e)) in b.iter().zip(reference).zip(areas) {
        for c in 0..3 {
            num += a * (x[c] - y[c]).abs();
            den += a * (y[c] - e[c]).abs();
        }
    }
    num / den
}

fn time_to(points: &[&Point], thr: f64, image: bool) -> Option<f64> {
    points
        .iter()
        .filter(|p| if image { p.err_image } else { p.err_surface } <= thr)
        .map(|p| if image { p.time_image } else { p.time_surface })
        .min_by(f64::total_cmp)
}

fn fmt_time(t: Option<f64>) -> String {
    t.map_or("not reached".into(), |t| format!("{t:.3} s"))
}

/// How a run solves a scene.
type SolveFn = Box<dyn Fn(&Scene) -> Result<Solution, SolverError>>;

/// One solver run of the sweep: method label, setting, and how to solve.
struct Run {
    method: String,
    setting: String,
    solve: SolveFn,
}

/// What one scene's solver sweep covers: gathering bases × levels × ε, shooting
/// (Haar) levels × ε.
struct Sweep {
    gather_bases: &'static [BasisKind],
    gather_levels: &'static [u8],
    gather_eps: &'static [f64],
    shoot_levels: &'static [u8],
    shoot_eps: &'static [f64],
}

impl Sweep {
    fn describe(&self) -> String {
        format!(
            "gather {} × levels {:?} × ε {:?}; shoot Haar × levels {:?} × ε {:?}",
            self.gather_bases
                .iter()
                .map(BasisKind::name)
                .collect::<Vec<_>>()
                .join("/"),
            self.gather_levels,
            self.gather_eps,
            self.shoot_levels,
            self.shoot_eps
        )
    }
}

/// The sweeps: the full one on the planar scenes; a small one where a run costs
/// minutes (the shooting solver on the Cornell box above level 2, every solver on the
/// 19-surface curved teapot); quick mode runs no shooting (CI time).
fn sweep(quick: bool, curved: bool) -> Sweep {
    const ALL: &[BasisKind] = &[
        BasisKind::Haar,
        BasisKind::Multiwavelet(2),
        BasisKind::Multiwavelet(3),
        BasisKind::Cdv,
    ];
    match (quick, curved) {
        // Quick mode (CI) keeps every gathering basis but leaves shooting to the
        // virtual-mesh reproductions: one shooting run on these scenes costs minutes.
        (true, false) => Sweep {
            gather_bases: ALL,
            gather_levels: &[2, 3],
            gather_eps: &[0.1, 0.03],
            shoot_levels: &[],
            shoot_eps: &[],
        },
        (true, true) => Sweep {
            gather_bases: &[BasisKind::Haar],
            gather_levels: &[2],
            gather_eps: &[0.1],
            shoot_levels: &[],
            shoot_eps: &[],
        },
        (false, true) => Sweep {
            gather_bases: &[BasisKind::Haar],
            gather_levels: &[2],
            gather_eps: &[0.1],
            shoot_levels: &[2],
            shoot_eps: &[0.1],
        },
        (false, false) => Sweep {
            gather_bases: ALL,
            gather_levels: &[2, 3, 4],
            gather_eps: &[0.1, 0.05, 0.02, 0.01],
            shoot_levels: &[2],
            shoot_eps: &[0.1, 0.03],
        },
    }
}

/// The solver runs of one sweep: gathering with GMRES, shooting to convergence 0.999.
fn solver_runs(sw: &Sweep) -> Vec<Run> {
    let mut runs = Vec::new();
    for &basis in sw.gather_bases {
        for &level in sw.gather_levels {
            for &eps in sw.gather_eps {
                let cfg = SolverConfig {
                    basis,
                    eps,
                    max_level: level,
                    linear_method: LinearMethod::Gmres { restart: 30 },
                    tolerance: 1e-8,
                    ..SolverConfig::default()
                };
                runs.push(Run {
                    method: format!("gather {}", basis.name()),
                    setting: format!("level {level}, ε {eps}"),
                    solve: Box::new(move |s: &Scene| solve(s, &cfg)),
                });
            }
        }
    }
    for &level in sw.shoot_levels {
        for &eps in sw.shoot_eps {
            let cfg = ShootConfig {
                basis: BasisKind::Haar,
                eps,
                max_level: level,
                convergence: SHOOT_CONVERGENCE,
                ..ShootConfig::default()
            };
            runs.push(Run {
                method: "shoot Haar".into(),
                setting: format!("level {level}, ε {eps}"),
                solve: Box::new(move |s: &Scene| shoot(s, &cfg)),
            });
        }
    }
    runs
}

/// Convergence target of the shooting runs (the unshot 0.1 % bounds their error).
const SHOOT_CONVERGENCE: f64 = 0.999;

fn pct(x: f64) -> String {
    if x.is_finite() {
        format!("{:.3}%", 100.0 * x)
    } else {
        "—".into()
    }
}

fn secs_cell(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.3}")
    } else {
        "—".into()
    }
}

/// Runs the reproduction.
pub fn run(ctx: &Ctx) -> anyhow::Result<Report> {
    let mut report = Report {
        paper_did: "No paper figure: the issue asks for a speed/accuracy chart of every \
method against the Monte Carlo reference so users can choose their trade."
            .into(),
        we_did: String::new(),
        ..Report::default()
    };
    let quick = ctx.quick;
    let (ref_spp, img) = if quick { (8usize, 48usize) } else { (48, 96) };
    let pt_samples: &[u64] = if quick {
        &[256, 1024, 4096]
    } else {
        &[256, 1024, 4096, 16384, 65536, 262_144, 1_048_576]
    };
    let pt_spp: &[usize] = if quick {
        &[1, 2]
    } else {
        &[1, 2, 4, 8, 16, 24]
    };
    // (name, scene, curved?, reference samples per surface)
    let scenes: Vec<(&str, Scene, bool, u64)> = vec![
        (
            "cornell-box",
            builtin::cornell_box(),
            false,
            if quick { 100_000 } else { 4_000_000 },
        ),
        (
            "ziegler-occluded",
            builtin::occluded(),
            false,
            if quick { 100_000 } else { 4_000_000 },
        ),
        (
            "quadric-teapot",
            builtin::builtin("quadric-teapot")
                .ok_or_else(|| anyhow::anyhow!("builtin quadric-teapot missing"))?,
            true,
            if quick { 20_000 } else { 300_000 },
        ),
    ];
    report.param(
        "reference samples per surface",
        scenes
            .iter()
            .map(|(n, _, _, r)| format!("{n} {r}"))
            .collect::<Vec<_>>()
            .join(", "),
    );
    report.param(
        "reference image",
        format!(
            "{img}² px, {ref_spp}² samples per pixel ({}² on the curved scene)",
            ref_spp / 2
        ),
    );
    let (flat_sweep, curved_sweep) = (sweep(quick, false), sweep(quick, true));
    report.param("planar scenes' solver sweep", flat_sweep.describe());
    report.param("curved scene's solver sweep", curved_sweep.describe());
    report.param("gathering linear solver", "GMRES(30), tolerance 1e-8");
    report.param("shooting convergence", SHOOT_CONVERGENCE);
    let flat = solver_runs(&flat_sweep);
    let curved = solver_runs(&curved_sweep);
    report.param(
        "path tracer samples per surface",
        format!("{pt_samples:?} (curved scene: up to 65536)"),
    );
    report.param("path tracer spp (per axis)", format!("{pt_spp:?}"));
    report.param(
        "threads",
        std::thread::available_parallelism().map_or(1, |n| n.get()),
    );

    let mut table_rows = Vec::new();
    for (name, scene, is_curved, ref_samples) in &scenes {
        let pt = PathTracer::new(scene)?;
        let areas: Vec<(f64, [f64; 3])> = scene
            .surfaces
            .iter()
            .map(|s| (s.shape.area(), scene.materials[s.material].emission.0))
            .collect();
        let ro = ReferenceOptions {
            seed: 12345,
            ..ReferenceOptions::default()
        };
        let t = Instant::now();
        let mut reference = Vec::new();
        let mut noise = Vec::new();
        for s in 0..scene.surfaces.len() {
            let e = pt.surface_average(s, *ref_samples, &ro)?;
            reference.push(e.mean);
            noise.push(e.std_error);
        }
        let view = view_for(scene, img)?;
        // The curved scene's reference image uses half the samples per axis (time).
        let spp = if *is_curved { ref_spp / 2 } else { ref_spp };
        let ref_img = pt.render(&view, spp, &ro, &|_| {})?;
        let ref_time = t.elapsed().as_secs_f64();
        // Σ A·σ / Σ A·B̂: the error measure of a one-σ deviation on every surface.
        let floor_surface = {
            let (mut num, mut den) = (0.0, 0.0);
            for ((se, r), (a, e)) in noise.iter().zip(&reference).zip(&areas) {
                for c in 0..3 {
                    num += a * se[c];
                    den += a * (r[c] - e[c]).abs();
                }
            }
            num / den
        };
        report.rows.push(
            Row::new(
                format!("{name}: reference noise floor (surface averages, 1σ relative)"),
                None,
                floor_surface,
                "",
                Tolerance::Info,
            )
            .comment(format!("reference computed in {ref_time:.1} s")),
        );
        let mut points: Vec<Point> = Vec::new();
        // Solver sweeps.
        let runs = if *is_curved { &curved } else { &flat };
        for r in runs {
            let t = Instant::now();
            let sol = match (r.solve)(scene) {
                Ok(s) => s,
                Err(e) => {
                    report.we_did.push_str(&format!(
                        "- {name}, {}, {}: solver error: {e}\n",
                        r.method, r.setting
                    ));
                    continue;
                }
            };
            let ts = t.elapsed().as_secs_f64();
            let b: Vec<[f64; 3]> = (0..scene.surfaces.len())
                .map(|s| sol.surface_average(s))
                .collect();
            let t2 = Instant::now();
            let image = SolutionField::new(&sol).and_then(|field| {
                render(
                    &field,
                    &view,
                    &RenderOptions {
                        spp: 2,
                        gather: 0,
                        seed: 1,
                    },
                    &|_| {},
                )
            });
            let (ti, ei) = match image {
                Ok((im, _)) => (
                    ts + t2.elapsed().as_secs_f64(),
                    im.metrics(&ref_img)?.relative_l1,
                ),
                Err(e) => {
                    report.we_did.push_str(&format!(
                        "- {name}, {}, {}: no image: {e}\n",
                        r.method, r.setting
                    ));
                    (f64::NAN, f64::NAN)
                }
            };
            points.push(Point {
                method: r.method.clone(),
                setting: r.setting.clone(),
                time_surface: ts,
                err_surface: surface_error(&b, &reference, &areas),
                time_image: ti,
                err_image: ei,
            });
        }
        // Path tracer at increasing sample counts (independent seed).
        let po = ReferenceOptions {
            seed: 777,
            ..ReferenceOptions::default()
        };
        for (k, &n) in pt_samples.iter().enumerate() {
            // The curved scene stops at 65 536 samples per surface (time).
            if *is_curved && n > 65_536 {
                continue;
            }
            let t = Instant::now();
            let mut b = Vec::new();
            for s in 0..scene.surfaces.len() {
                b.push(pt.surface_average(s, n, &po)?.mean);
            }
            let ts = t.elapsed().as_secs_f64();
            let (ti, ei) = match pt_spp.get(k) {
                Some(&spp) => {
                    let t = Instant::now();
                    let im: Image = pt.render(&view, spp, &po, &|_| {})?;
                    (t.elapsed().as_secs_f64(), im.metrics(&ref_img)?.relative_l1)
                }
                None => (f64::NAN, f64::NAN),
            };
            points.push(Point {
                method: "path tracer".into(),
                setting: format!(
                    "{n} samples/surface{}",
                    pt_spp
                        .get(k)
                        .map_or(String::new(), |s| format!(", {s}² spp"))
                ),
                time_surface: ts,
                err_surface: surface_error(&b, &reference, &areas),
                time_image: ti,
                err_image: ei,
            });
        }
        // Plots and table.
        let mut methods: Vec<String> = Vec::new();
        for p in &points {
            if !methods.contains(&p.method) {
                methods.push(p.method.clone());
            }
        }
        for (image, what) in [(false, "surface"), (true, "pixel")] {
            let series: Vec<Series> = methods
                .iter()
                .map(|m| {
                    let pts = points
                        .iter()
                        .filter(|p| p.method == *m)
                        .map(|p| {
                            if image {
                                (p.time_image, p.err_image)
                            } else {
                                (p.time_surface, p.err_surface)
                            }
                        })
                        .filter(|(t, e)| t.is_finite() && e.is_finite() && *e > 0.0)
                        .collect();
                    Series::new(m.clone(), pts, Style::Points)
                })
                .collect();
            let path = ctx.figure_path(&format!("{name}-{what}.svg"));
            xy_plot(
                &path,
                &format!("{name}: {what} relative L1 error vs wall time"),
                &Axis::log("wall time (s)"),
                &Axis::log("relative L1 error"),
                &series,
            )?;
            report.figures.push(Figure {
                path,
                caption: format!(
                    "{name}: {} error against the path-traced reference vs wall time, one \
marker per run (gathering and shooting: every basis, level and ε of the sweep; path tracer: \
increasing samples). The lower-left envelope is the Pareto front.",
                    if image {
                        "per-pixel relative L1"
                    } else {
                        "per-surface average"
                    }
                ),
            });
        }
        for m in &methods {
            let pts: Vec<&Point> = points.iter().filter(|p| p.method == *m).collect();
            let best = pts
                .iter()
                .map(|p| p.err_surface)
                .fold(f64::INFINITY, f64::min);
            for (thr, label) in [(0.01, "1%"), (0.001, "0.1%")] {
                let ts = time_to(&pts, thr, false);
                report.rows.push(
                    Row::new(
                        format!("{name}: {m}: time to {label} surface-average error"),
                        None,
                        ts.unwrap_or(f64::NAN),
                        "s",
                        Tolerance::Info,
                    )
                    .comment(if ts.is_some() {
                        "smallest wall time among the runs that reached it".to_string()
                    } else {
                        format!("not reached by the sweep (best {:.3}%)", 100.0 * best)
                    }),
                );
            }
            table_rows.push(vec![
                name.to_string(),
                m.clone(),
                fmt_time(time_to(&pts, 0.01, false)),
                fmt_time(time_to(&pts, 0.001, false)),
                fmt_time(time_to(&pts, 0.01, true)),
                fmt_time(time_to(&pts, 0.001, true)),
                pct(best),
            ]);
        }
        report.tables.push(Table {
            title: format!("{name}: every run"),
            headers: [
                "method",
                "setting",
                "solve time (s)",
                "surface error",
                "solve + image time (s)",
                "pixel error",
            ]
            .map(String::from)
            .to_vec(),
            rows: points
                .iter()
                .map(|p| {
                    vec![
                        p.method.clone(),
                        p.setting.clone(),
                        secs_cell(p.time_surface),
                        pct(p.err_surface),
                        secs_cell(p.time_image),
                        pct(p.err_image),
                    ]
                })
                .collect(),
        });
    }
    report.tables.insert(
        0,
        Table {
            title: "Time to reach 1 % and 0.1 % relative L1 error".into(),
            headers: [
                "scene",
                "method",
                "surface 1%",
                "surface 0.1%",
                "pixel 1%",
                "pixel 0.1%",
                "best surface error",
            ]
            .map(String::from)
            .to_vec(),
            rows: table_rows,
        },
    );
    report.we_did.insert_str(
        0,
        "Reference: wavelux-render's path tracer (next-event estimation with MIS, Russian \
roulette; points and light samples drawn exactly by area on every primitive kind, curved \
and trimmed included), per-surface averages from uniformly distributed points and a \
path-traced image at the same camera. Gathering runs: `solve` with GMRES. Shooting runs: \
the linkless Virtual Mesh shooting solver (`shoot`, Southwell order, Haar) until 99.9 % of \
the emitted power is propagated; its sweep is small (level 2) because a shooting run costs \
tens of seconds on the Cornell box at level 2 and minutes above (see the every-run tables). Images of solver runs: no final gather (the solution itself, \
2×2 samples per pixel). Path tracer runs: an independent seed, samples per surface and \
samples per pixel increasing together. Times are wall times on this machine with all \
threads. The curved-surface scene is VirtualMesh §6.2's quadric teapot (12 trimmed quadric \
patches and 7 complex polygons over a plate); every run on it costs minutes, so its sweep is \
one gathering and one shooting run, and its reference uses fewer samples (see the \
parameters), so its noise floor is higher. Errors below a reference's noise floor are not \
resolved. Solver or image failures, if any, are listed here:\n\n",
    );
    Ok(report)
}
