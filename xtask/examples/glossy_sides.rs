//! The per-side table of docs/architecture.md's "A cosine-weighted direction map keeps
//! a coarse node's energy" (Glossy §3.3, issue 16): the glossy method's front-side
//! mean exitance of every surface against the independent glossy path tracer, after
//! `ROUNDS` refinement rounds, for the Ward Cornell box with the paper's direction map
//! and the cosine-weighted map, and for the diffuse built-in Cornell box.
//!
//! Usage: `cargo run -p xtask --example glossy_sides [-- ROUNDS PATHS TABLES]`
//! (defaults 4 rounds, 16,384 paths per side and the three tables
//! `ward-glossy,ward-cosine,cornell`; run from the workspace root). The glossy
//! configuration is the library's default (`GlossyConfig::default()`: Bounded Ward,
//! Gauss–Seidel to 1e-6, fraction 0.1, max level 5, importance off, seed 0) with the
//! map and rounds set; the tracer uses `ReferenceOptions::default()` with seed 11.
//! Prints, per surface and RGB channel, `ours / reference − 1` in percent and the
//! reference's standard error relative to its mean (σ), then the solve's CPU seconds
//! and links. Every number is deterministic (seeded) except the CPU seconds.

#[allow(dead_code)]
#[path = "../src/cpu.rs"]
mod cpu;

use cpu::Stopwatch;
use wavelux::glossy::{DirectionKind, GlossyConfig, GlossySolution};
use wavelux::render::{GlossyTracer, ReferenceOptions};
use wavelux::scene::Scene;
use wavelux::support::Side;

/// Prints one scene's table.
fn table(name: &str, scene: &Scene, directions: DirectionKind, rounds: usize, paths: u64) {
    let run = || -> anyhow::Result<()> {
        let t = Stopwatch::start();
        let mut sol = GlossySolution::new(
            scene,
            name,
            GlossyConfig {
                directions,
                rounds,
                ..GlossyConfig::default()
            },
        )?;
        sol.run(|_| {})?;
        let cpu = t.elapsed().cpu_or_wall();
        println!(
            "== {name}, {} map, {rounds} rounds: {cpu:.2} s CPU, {} links",
            directions.name(),
            sol.stats.links
        );
        let tracer = GlossyTracer::new(&sol.scene);
        let opts = ReferenceOptions {
            seed: 11,
            ..ReferenceOptions::default()
        };
        for (i, s) in scene.surfaces.iter().enumerate() {
            let (Some(ours), Ok(reference)) = (
                sol.side_exitance(i, Side::Front),
                tracer.side_exitance(i, Side::Front, paths, &opts),
            ) else {
                println!("{:<12} (no estimate)", s.name);
                continue;
            };
            let cells: Vec<String> = (0..3)
                .map(|c| {
                    let m = reference.mean[c];
                    format!(
                        "{:+7.2} % (σ {:.2} %)",
                        100.0 * (ours[c] / m - 1.0),
                        100.0 * reference.std_error[c] / m
                    )
                })
                .collect();
            println!("{:<12} {}", s.name, cells.join("  "));
        }
        Ok(())
    };
    if let Err(e) = run() {
        println!("== {name}: {e:#}");
    }
}

fn main() -> anyhow::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let rounds = args.first().map_or(Ok(4), |a| a.parse())?;
    let paths = args.get(1).map_or(Ok(16_384), |a| a.parse())?;
    let wanted = args
        .get(2)
        .map_or("ward-glossy,ward-cosine,cornell", String::as_str);
    let want = |name: &str| wanted.split(',').any(|w| w == name);
    let ward = wavelux::scene::load("docs/scenes/ward-cornell.toml")?;
    for (name, directions) in [
        ("ward-glossy", DirectionKind::Glossy),
        ("ward-cosine", DirectionKind::Cosine),
    ] {
        if want(name) {
            table("ward-cornell", &ward, directions, rounds, paths);
        }
    }
    if want("cornell") {
        let diffuse = wavelux::scene::builtin::cornell_box();
        table(
            "cornell-box",
            &diffuse,
            DirectionKind::Cosine,
            rounds,
            paths,
        );
    }
    Ok(())
}
