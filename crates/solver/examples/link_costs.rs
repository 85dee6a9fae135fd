//! What a transfer block costs, per class of link (issue 12 §3): solves a scene to a
//! target error as `wavelux solve` does by default (`--target-error 2%`, every face
//! 2 %, GMRES, level limit 10), then recomputes the block of every final link
//! (closure links aside) on one thread (twice: first to learn what its rays saw),
//! grouped by separation (centre distance over
//! the sum of the bounding-sphere radii: far ≥ 3, mid 1–3, near < 1, the near field
//! the blocks split) and by what the block's shadow rays saw, and prints per class the
//! links, shadow rays and kernel evaluations per link and the CPU time of the class.
//!
//! `RAYON_NUM_THREADS=1 cargo run --release -p wavelux-solver --example link_costs --
//! [scene] [links file]` (default `cornell-box`; a links file written by an earlier
//! run is read instead of solving again). CPU time is this thread's
//! `/proc/thread-self/schedstat` (Linux; the kernel updates it every few
//! milliseconds, so a class of a few links may read 0); elsewhere wall time is printed
//! instead.

use std::collections::BTreeMap;
use std::io::Write;
use std::sync::atomic::Ordering;
use std::time::Instant;

use wavelux_solver::{
    BasisKind, LinearMethod, NodeKey, Oracle, Prepared, TargetConfig, closure, solve_to_target,
};

/// This thread's CPU time (s), if the kernel says.
fn thread_cpu() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn parse_links(text: &str) -> Result<Vec<(NodeKey, NodeKey)>, Box<dyn std::error::Error>> {
    let mut out = Vec::new();
    for line in text.lines() {
        let v: Vec<u32> = line
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()?;
        if v.len() != 8 {
            return Err(format!("links file: bad line {line:?}").into());
        }
        let key = |o: usize| -> Result<NodeKey, Box<dyn std::error::Error>> {
            Ok(NodeKey {
                level: u8::try_from(v[o])?,
                patch: v[o + 1],
                iy: v[o + 2],
                ix: v[o + 3],
            })
        };
        out.push((key(0)?, key(4)?));
    }
    Ok(out)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let name = args.get(1).map_or("cornell-box", String::as_str);
    let scene = wavelux_scene::builtin::builtin(name).ok_or("unknown built-in scene")?;
    let mut cfg = TargetConfig {
        target: 0.02,
        ..TargetConfig::default()
    };
    cfg.solver.max_iterations = 100;
    cfg.solver.linear_method = LinearMethod::Gmres { restart: 30 };
    let file = args.get(2);
    let (keys, basis) = match file.and_then(|f| std::fs::read_to_string(f).ok()) {
        Some(text) => (parse_links(&text)?, BasisKind::Multiwavelet(3)),
        None => {
            let t = Instant::now();
            let out = solve_to_target(&scene, &cfg)?;
            eprintln!(
                "solved to the target in {:.1} s wall, {} rounds",
                t.elapsed().as_secs_f64(),
                out.rounds.len()
            );
            let mut keys = Vec::new();
            for l in out.solution.system().hierarchy().links() {
                if !closure::is_closure_link(&out.solution.patches, &l) {
                    keys.push((l.r, l.e));
                }
            }
            if let Some(f) = file {
                let mut w = std::io::BufWriter::new(std::fs::File::create(f)?);
                for (r, e) in &keys {
                    let (a, b) = (r, e);
                    writeln!(
                        w,
                        "{} {} {} {} {} {} {} {}",
                        a.level, a.patch, a.iy, a.ix, b.level, b.patch, b.iy, b.ix
                    )?;
                }
            }
            (keys, out.choice.basis)
        }
    };
    // The context the loop refines with (brightness oracle, visibility samples).
    let mut scfg = cfg.solver;
    scfg.oracle = Oracle::Brightness;
    scfg.oracle_visibility = true;
    scfg.basis = basis;
    let prep = Prepared::new(&scene, &scfg)?;
    let ctx = prep.transfer()?;
    let patches = &prep.patches.patches;
    let mut classes: BTreeMap<&str, Vec<(NodeKey, NodeKey)>> = BTreeMap::new();
    for (r, e) in &keys {
        let (rr, er) = (r.region(), e.region());
        let (cr, ra) = patches[rr.patch]
            .support
            .bounding_sphere(rr.s0, rr.t0, rr.h);
        let (ce, rb) = patches[er.patch]
            .support
            .bounding_sphere(er.s0, er.t0, er.h);
        let sep = (cr - ce).length() / (ra + rb);
        let class = if sep >= 3.0 {
            "far"
        } else if sep >= scfg.near_field {
            "mid"
        } else {
            "near"
        };
        classes.entry(class).or_default().push((*r, *e));
    }
    let clock = if thread_cpu().is_some() {
        "CPU"
    } else {
        "wall"
    };
    println!("{} links of {name}, basis {}", keys.len(), basis.name());
    println!(
        "| separation | seen | links | rays per link | kernel evaluations per link | {clock} s | µs per link |"
    );
    println!("| --- | --- | --- | --- | --- | --- | --- |");
    // What each block's rays saw (a first pass), then the blocks of each (class,
    // seen) group again, timed together (one clock reading per group).
    let mut groups: BTreeMap<(&str, String), Vec<(NodeKey, NodeKey)>> = BTreeMap::new();
    for (class, links) in &classes {
        for (r, e) in links {
            let (_, seen) = ctx.block_seen(&r.region(), &e.region());
            groups
                .entry((class, format!("{seen:?}")))
                .or_default()
                .push((*r, *e));
        }
    }
    // (links, rays, evaluations, seconds) per group.
    let mut rows: BTreeMap<(&str, String), (u64, u64, u64, f64)> = BTreeMap::new();
    for (group, links) in &groups {
        let (rays0, evals0) = (
            ctx.rays.load(Ordering::Relaxed),
            ctx.kernel_evals.load(Ordering::Relaxed),
        );
        let (t0, w0) = (thread_cpu(), Instant::now());
        for (r, e) in links {
            std::hint::black_box(ctx.block_seen(&r.region(), &e.region()));
        }
        let secs = match (t0, thread_cpu()) {
            (Some(a), Some(b)) => b - a,
            _ => w0.elapsed().as_secs_f64(),
        };
        rows.insert(
            group.clone(),
            (
                links.len() as u64,
                ctx.rays.load(Ordering::Relaxed) - rays0,
                ctx.kernel_evals.load(Ordering::Relaxed) - evals0,
                secs,
            ),
        );
    }
    let mut all = (0u64, 0u64, 0u64, 0.0f64);
    for ((class, seen), (n, rays, evals, secs)) in &rows {
        let per = |x: u64| x as f64 / *n as f64;
        println!(
            "| {class} | {seen} | {n} | {:.0} | {:.0} | {secs:.2} | {:.1} |",
            per(*rays),
            per(*evals),
            secs * 1e6 / *n as f64
        );
        all = (all.0 + n, all.1 + rays, all.2 + evals, all.3 + secs);
    }
    let per = |x: u64| x as f64 / all.0 as f64;
    println!(
        "| all | | {} | {:.0} | {:.0} | {:.2} | {:.1} |",
        all.0,
        per(all.1),
        per(all.2),
        all.3,
        all.3 * 1e6 / all.0 as f64
    );
    Ok(())
}
