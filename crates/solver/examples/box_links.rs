//! Prints link counts and timings of Ziegler's §4.2 box scene for a level and ε
//! (`cargo run --release -p wavelux-solver --example box_links -- <level> <eps> [cube]`).

use wavelux_scene::builtin::{BoxVariant, Reflectivity, ziegler_box};
use wavelux_solver::{Hierarchy, Prepared, SolverConfig, hierarchy};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().collect();
    let level: u8 = args.get(1).map_or(Ok(3), |s| s.parse())?;
    let eps: f64 = args.get(2).map_or(Ok(1e-4), |s| s.parse())?;
    let cube = args.get(3).is_some_and(|s| s == "cube");
    let scene = ziegler_box(cube, Reflectivity::High, BoxVariant::A);
    let cfg = SolverConfig {
        eps,
        max_level: level,
        ..SolverConfig::default()
    };
    let t = std::time::Instant::now();
    let prep = Prepared::new(&scene, &cfg)?;
    let ctx = prep.transfer()?;
    let (links, counts) = hierarchy::refine_all(&ctx, &prep.refine_params(eps), &|_| 1.0);
    let h = Hierarchy::compile(prep.basis.n(), prep.patches.patches.len(), &links);
    println!(
        "level {level} eps {eps:e} cube {cube}: nonstandard {} blocks {} nodes {} rays {} time {:.1}s",
        counts.refined + counts.unrefined_roots,
        h.link_count(),
        h.node_count(),
        ctx.rays.load(std::sync::atomic::Ordering::Relaxed),
        t.elapsed().as_secs_f64()
    );
    Ok(())
}
