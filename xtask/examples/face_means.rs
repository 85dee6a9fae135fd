//! The mean radiosity of every face of `cornell-faces` (issue 11 §2's glTF Cornell box
//! with one node per face), solved as the reproduction solves it (the command's
//! default: target error 2 %, max level 10), printed to 17 digits with the links and
//! the support kinds. For comparing two builds bitwise (a solver change's effect on
//! the reproduction's rows, which are these means against a path tracer), without the
//! reproduction's reference walks.
//!
//! Usage: `cargo run -p xtask --example face_means` (one thread for repeatable
//! timing: `RAYON_NUM_THREADS=1`; the means do not depend on the thread count).

use wavelux::scene::{
    GltfOptions, TessellateOptions, fixtures, load_gltf_slice, tessellated, to_glb,
};
use wavelux::solver::{TargetConfig, solve_to_target};
use wavelux::support::SupportMap;

fn main() -> anyhow::Result<()> {
    let faces = tessellated(&fixtures::cornell_faces(), &TessellateOptions::default())?;
    let glb = to_glb(&faces, "cornell-faces.glb")?;
    let scene = load_gltf_slice(&glb, "cornell-faces.glb", None, &GltfOptions::default())?;
    let mut cfg = TargetConfig {
        target: 0.02,
        ..TargetConfig::default()
    };
    cfg.solver.max_level = 10;
    let sol = solve_to_target(&scene, &cfg)?.solution;
    println!("links {} leaves {}", sol.stats.links, sol.stats.leaves);
    let (mut affine, mut triangle, mut other) = (0, 0, 0);
    for p in &sol.patches {
        match p.support.map {
            SupportMap::Parallelogram { .. } => affine += 1,
            SupportMap::Triangle { .. } => triangle += 1,
            _ => other += 1,
        }
    }
    println!("supports: {affine} parallelograms, {triangle} triangles, {other} other");
    for (i, s) in scene.surfaces.iter().enumerate() {
        let m = sol.lit_average(i);
        println!("{:<14} {:.17e} {:.17e} {:.17e}", s.name, m[0], m[1], m[2]);
    }
    Ok(())
}
