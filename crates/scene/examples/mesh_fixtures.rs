//! Writes the tessellated test scenes of `wavelux_scene::fixtures` as GLB files, the
//! inputs of the mesh-grouping measurements (docs/performance.md):
//!
//! ```sh
//! cargo run --release -p wavelux-scene --example mesh_fixtures -- DIR
//! wavelux solve DIR/coaxial-disks-2048.glb --no-image --samples 0
//! ```
//!
//! - `coaxial-disks-2048.glb`: two coaxial unit disks 1 apart, each 128 sectors × 8
//!   rings = 2,048 triangles (128 degenerate at the centre);
//! - `closed-sphere-5040.glb`: a unit UV sphere, 72 × 36, 5,040 triangles, facing
//!   inwards, `ρ = 0.5`, `E = 1` (exact `B = 2`);
//! - `cornell-faces.glb`: the Cornell box with one node per face (floor and ceiling
//!   with holes, triangulated without Steiner points).

use std::path::PathBuf;

use wavelux_scene::{TessellateOptions, fixtures, tessellated, write_glb};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = PathBuf::from(std::env::args().nth(1).unwrap_or_else(|| "out".into()));
    std::fs::create_dir_all(&dir)?;
    let scenes = [
        (
            "coaxial-disks-2048.glb",
            fixtures::coaxial_disks(1.0, 1.0, 128, 8),
        ),
        (
            "closed-sphere-5040.glb",
            fixtures::closed_sphere(1.0, 72, 36, 0.5, 1.0)?,
        ),
        (
            "cornell-faces.glb",
            tessellated(&fixtures::cornell_faces(), &TessellateOptions::default())?,
        ),
    ];
    for (name, scene) in scenes {
        let path = dir.join(name);
        write_glb(&scene, &path)?;
        let triangles: usize = scene
            .surfaces
            .iter()
            .map(|s| match &s.shape {
                wavelux_scene::Shape::Mesh(m) => m.triangle_count(),
                wavelux_scene::Shape::Parallelogram { .. } => 2,
                _ => 1,
            })
            .sum();
        println!(
            "wrote {} ({} surfaces, {triangles} triangles)",
            path.display(),
            scene.surfaces.len()
        );
    }
    Ok(())
}
