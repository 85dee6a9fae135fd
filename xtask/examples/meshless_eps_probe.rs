//! What limits the ε = 0.005 Cornell-box target of issue 15 (`meshless-scaling`'s
//! "indirect relative L1 vs path tracer" rows): the target's configuration (R_coarse
//! 0.068 m, 3 receiver / 2 sender levels, 8 bounces, bounce threshold ε/100, the
//! scene's own light by next-event estimation with 64 samples) rerun with other gather
//! rays, thresholds and level-0 dropped shares, each measured against the same
//! path-traced reference as the reproduction's full run (1,000 camera points, 16,384
//! walks each, seed 7; cached under `target/` after the first call).
//!
//! Usage: `cargo run --release -p xtask --example meshless_eps_probe -- SPEC...` with
//! each `SPEC = rays:seed:share:eps` (`share` 0: the seed's criteria alone). Prints the
//! relative L1 (the reproduction's measure, reference noise included), the energy
//! kept, the links of T and S, and the relative L1 between each pair of runs.

#[allow(dead_code)]
#[path = "../src/cpu.rs"]
mod cpu;
#[allow(dead_code)]
#[path = "../src/repro/meshless_common.rs"]
mod meshless_common;

use meshless_common::{
    at_points, energy_ratio, precompute, reference_indirect, relative_l1, scene, scene_direct,
    visible_points,
};
use wavelux::meshless::{CpuBackend, LinkThreshold, MeshlessConfig, Relighter, SceneSurfaces};
use wavelux::render::PathTracer;

/// One probe configuration, parsed from `rays:seed:share:eps`.
struct Spec {
    rays: usize,
    seed: u64,
    share: f64,
    eps: f64,
}

fn parse(spec: &str) -> anyhow::Result<Spec> {
    let f: Vec<&str> = spec.split(':').collect();
    anyhow::ensure!(f.len() == 4, "{spec}: expected rays:seed:share:eps");
    Ok(Spec {
        rays: f[0].parse()?,
        seed: f[1].parse()?,
        share: f[2].parse()?,
        eps: f[3].parse()?,
    })
}

fn main() -> anyhow::Result<()> {
    let specs: Vec<String> = std::env::args().skip(1).collect();
    let scene = scene("cornell-box")?;
    let query = SceneSurfaces::new(&scene)?;
    let points = visible_points(&scene, &query, 1000)?;
    let cache = "target/meshless-eps-probe-reference.json";
    let reference: Vec<([f64; 3], [f64; 3])> = match std::fs::read_to_string(cache) {
        Ok(text) => serde_json::from_str(&text)?,
        Err(_) => {
            let r = reference_indirect(&PathTracer::new(&scene)?, &points, 16384, 7)?;
            std::fs::write(cache, serde_json::to_string(&r)?)?;
            r
        }
    };
    let means: Vec<[f64; 3]> = reference.iter().map(|(m, _)| *m).collect();
    println!(
        "reference noise floor {:.2} %",
        100.0 * relative_l1(&means, &reference).1
    );
    let mut runs: Vec<(String, Vec<[f64; 3]>)> = Vec::new();
    for spec in &specs {
        let p = parse(spec)?;
        let cfg = MeshlessConfig {
            receiver_levels: 3,
            sender_levels: 2,
            r_coarse: Some(0.068),
            gather_rays: p.rays,
            epsilon: p.eps,
            threshold: LinkThreshold::Uniform,
            bounces: 8,
            bounce_epsilon: Some(p.eps / 100.0),
            max_dropped_share: (p.share > 0.0).then_some(p.share),
            seed: p.seed,
            ..MeshlessConfig::default()
        };
        let (pre, time) = precompute(&scene, &cfg)?;
        let direct = scene_direct(&scene, &query, 64, 1);
        let ind = Relighter::new(&pre, CpuBackend)?.relight_with(&query, &direct)?;
        let ours = at_points(&ind, &points);
        println!(
            "{spec}: relative L1 {:.2} %, energy {:.3}, links T {}, S {}, precompute {:.1} CPU s",
            100.0 * relative_l1(&ours, &reference).0,
            energy_ratio(&ours, &reference),
            pre.t.nnz(),
            pre.s.nnz(),
            time.total.cpu_or_wall()
        );
        for (name, other) in &runs {
            let exact: Vec<_> = other.iter().map(|&m| (m, [0.0; 3])).collect();
            println!(
                "    vs {name}: {:.2} %",
                100.0 * relative_l1(&ours, &exact).0
            );
        }
        runs.push((spec.clone(), ours));
    }
    Ok(())
}
