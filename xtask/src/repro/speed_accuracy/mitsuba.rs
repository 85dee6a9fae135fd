//! Mitsuba 3 rows (issue 12 §1): when `python3 -c "import mitsuba"` works and its
//! `llvm_ad_rgb` variant loads, the scene is exported to Mitsuba and its `path`
//! integrator renders the same camera and estimates the same texels, timed in the same
//! run as our methods (`mitsuba.py` beside this file does the Mitsuba side), by the CPU
//! time of the Mitsuba process like ours.
//!
//! The conversion: every scene surface becomes one PLY mesh — its exact primitives
//! tessellated by `wavelux_geometry::tessellate` (planar pieces exactly, curved
//! patches adaptively to a chordal tolerance of 1e-4 of each primitive's diagonal)
//! with the exact per-vertex normals as shading normals; the front side a `diffuse`
//! BSDF with our reflectance (texture means applied), two-sided surfaces a
//! `twosided` BSDF with the back reflectance; emitters an `area` emitter of radiance
//! `E/π` (Mitsuba's emitters are one-sided, as ours are on their front). The camera is
//! a `perspective` sensor with our vertical field of view, a box filter and a
//! stratified sampler. A texel on a curved patch starts its rays 3 × the chordal
//! tolerance off the exact surface, so it lies outside the tessellation.

use std::path::{Path, PathBuf};
use std::process::Command;

use serde::{Deserialize, Serialize};
use wavelux::geometry::{TessellationOptions, tessellate};
use wavelux::param::glam::DVec3;
use wavelux::render::{Image, PathTracer};
use wavelux::scene::Scene;

use super::measure::{Point, Refs, measure_external};

/// The script, written to a temporary directory at run time.
const SCRIPT: &str = include_str!("mitsuba.py");
/// Mitsuba variant (CPU, LLVM JIT, RGB).
const VARIANT: &str = "llvm_ad_rgb";
/// Chordal tolerance of curved patches (relative to each primitive's diagonal).
const CHORD: f64 = 1e-4;

#[derive(Serialize)]
struct Side {
    rho: [f64; 3],
    e: [f64; 3],
}

#[derive(Serialize)]
struct Mesh {
    ply: String,
    front: Side,
    back: Option<Side>,
}

#[derive(Serialize)]
struct CameraJob {
    origin: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
    fov_y_deg: f64,
    width: usize,
    height: usize,
}

#[derive(Serialize)]
struct TexelJob {
    origin: Vec<f64>,
    normal: Vec<f64>,
    rho: Vec<f64>,
    e: Vec<f64>,
}

#[derive(Serialize)]
struct Job {
    variant: &'static str,
    meshes: Vec<Mesh>,
    camera: CameraJob,
    texels: TexelJob,
    image_spp: Vec<usize>,
    texel_paths: Vec<u64>,
}

#[derive(Deserialize)]
struct ImageOut {
    spp: usize,
    /// CPU time of the Mitsuba process for this render (s; its wall time is also in
    /// the JSON, unused).
    seconds: f64,
    pixels: Vec<f64>,
}

#[derive(Deserialize)]
struct TexelOut {
    paths: u64,
    /// CPU time of the Mitsuba process for these texels (s).
    seconds: f64,
    values: Vec<f64>,
}

#[derive(Deserialize)]
struct Output {
    version: String,
    images: Vec<ImageOut>,
    texels: Vec<TexelOut>,
}

/// Why Mitsuba cannot run here, if it cannot.
fn available() -> Result<(), String> {
    let out = Command::new("python3")
        .args([
            "-c",
            &format!("import mitsuba as mi; mi.set_variant('{VARIANT}'); mi.Float(1)"),
        ])
        .output()
        .map_err(|e| format!("python3 not runnable: {e}"))?;
    if out.status.success() {
        Ok(())
    } else {
        let err = String::from_utf8_lossy(&out.stderr);
        Err(format!(
            "`import mitsuba` with variant {VARIANT} failed: {}",
            err.lines().last().unwrap_or("unknown error")
        ))
    }
}

/// Writes a binary little-endian PLY with positions and normals.
fn write_ply(path: &Path, pos: &[DVec3], nrm: &[DVec3], tris: &[[u32; 3]]) -> anyhow::Result<()> {
    let mut b = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\n\
property float y\nproperty float z\nproperty float nx\nproperty float ny\nproperty float nz\n\
element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        pos.len(),
        tris.len()
    )
    .into_bytes();
    for (p, n) in pos.iter().zip(nrm) {
        for v in [p.x, p.y, p.z, n.x, n.y, n.z] {
            b.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    for t in tris {
        b.push(3);
        for &i in t {
            b.extend_from_slice(&(i as i32).to_le_bytes());
        }
    }
    std::fs::write(path, b)?;
    Ok(())
}

/// The job: meshes (written as PLY into `dir`), camera, texels.
fn job(scene: &Scene, refs: &Refs, levels: &[(u64, usize)], dir: &Path) -> anyhow::Result<Job> {
    let pt = PathTracer::new(scene)?;
    let prims = scene.primitives(&scene.name)?;
    let opts = TessellationOptions {
        chord_tolerance: CHORD,
        ..TessellationOptions::default()
    };
    let mut meshes = Vec::new();
    for (si, surf) in scene.surfaces.iter().enumerate() {
        let (mut pos, mut nrm, mut tris) = (Vec::new(), Vec::new(), Vec::new());
        for (_, p) in prims.iter().filter(|(s, _)| *s == si) {
            let m = tessellate(p, &opts)?;
            let base = pos.len() as u32;
            pos.extend_from_slice(&m.positions);
            nrm.extend_from_slice(&m.normals);
            tris.extend(m.indices.iter().map(|t| t.map(|i| i + base)));
        }
        let side = |back| pt.side_material(si, back).map(|(rho, e)| Side { rho, e });
        let front = side(false).ok_or_else(|| anyhow::anyhow!("{}: no front side", surf.name))?;
        let back = side(true);
        if back.as_ref().is_some_and(|b| b.e.iter().any(|&v| v > 0.0)) {
            anyhow::bail!(
                "{}: an emitting back side has no one-mesh Mitsuba equivalent",
                surf.name
            );
        }
        let ply = dir.join(format!("s{si}.ply"));
        write_ply(&ply, &pos, &nrm, &tris)?;
        meshes.push(Mesh {
            ply: ply.display().to_string(),
            front,
            back,
        });
    }
    let diag = pt.accel().bounds().diagonal().length();
    let mut tx = TexelJob {
        origin: Vec::new(),
        normal: Vec::new(),
        rho: Vec::new(),
        e: Vec::new(),
    };
    for t in &refs.grid.texels {
        let p = &prims[t.prim as usize].1;
        let delta = if p.is_planar() {
            1e-6 * diag
        } else {
            let b = p.aabb();
            3.0 * CHORD * (b.max - b.min).length()
        };
        let n = DVec3::from_array(t.normal);
        let o = DVec3::from_array(t.point) + n * delta;
        tx.origin.extend(o.to_array());
        tx.normal.extend(t.normal);
        let (rho, e) = pt
            .side_material(t.surface, t.back)
            .ok_or_else(|| anyhow::anyhow!("texel on a black side"))?;
        tx.rho.extend(rho);
        tx.e.extend(e);
    }
    let v = &refs.view;
    let fov = match v.projection {
        wavelux::scene::Projection::Perspective { yfov, .. } => yfov.to_degrees(),
        _ => anyhow::bail!("Mitsuba rows need a perspective camera"),
    };
    Ok(Job {
        variant: VARIANT,
        meshes,
        camera: CameraJob {
            origin: v.position.to_array(),
            target: (v.position + v.forward).to_array(),
            up: v.up.to_array(),
            fov_y_deg: fov,
            width: v.width,
            height: v.height,
        },
        texels: tx,
        image_spp: levels.iter().map(|l| l.1).collect(),
        texel_paths: levels.iter().map(|l| l.0).collect(),
    })
}

/// A temporary directory removed on drop.
struct TempDir(PathBuf);

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// Mitsuba's rows on `scene`, one per level `(walks per texel, spp per axis)`, or why
/// they were skipped.
pub fn runs(scene: &Scene, refs: &Refs, levels: &[(u64, usize)]) -> Result<Vec<Point>, String> {
    if levels.is_empty() {
        return Ok(Vec::new());
    }
    available()?;
    run_job(scene, refs, levels).map_err(|e| format!("Mitsuba run failed: {e:#}"))
}

fn run_job(scene: &Scene, refs: &Refs, levels: &[(u64, usize)]) -> anyhow::Result<Vec<Point>> {
    let dir = TempDir(std::env::temp_dir().join(format!(
        "wavelux-mitsuba-{}-{}",
        std::process::id(),
        scene.name
    )));
    std::fs::create_dir_all(&dir.0)?;
    let job = job(scene, refs, levels, &dir.0)?;
    let (job_path, out_path, script) = (
        dir.0.join("job.json"),
        dir.0.join("out.json"),
        dir.0.join("wavelux_mitsuba.py"),
    );
    std::fs::write(&job_path, serde_json::to_vec(&job)?)?;
    std::fs::write(&script, SCRIPT)?;
    let st = Command::new("python3")
        .arg(&script)
        .arg(&job_path)
        .arg(&out_path)
        .output()?;
    if !st.status.success() {
        let err = String::from_utf8_lossy(&st.stderr);
        anyhow::bail!(
            "mitsuba.py exited with {}: {}",
            st.status,
            err.lines().rev().take(5).collect::<Vec<_>>().join(" | ")
        );
    }
    let out: Output = serde_json::from_slice(&std::fs::read(&out_path)?)?;
    let (w, h) = (refs.view.width, refs.view.height);
    let mut points = Vec::new();
    for (img, tx) in out.images.iter().zip(&out.texels) {
        if img.pixels.len() != 3 * w * h || tx.values.len() != 3 * refs.grid.len() {
            anyhow::bail!("mitsuba.py returned arrays of the wrong size");
        }
        let mut im = Image::new(w, h);
        for (i, p) in im.pixels.iter_mut().enumerate() {
            *p = [0, 1, 2].map(|c| img.pixels[3 * i + c]);
        }
        let vals: Vec<[f64; 3]> = tx
            .values
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        points.push(measure_external(
            &format!("Mitsuba {} path", out.version),
            &format!("{} walks/texel, {}² spp", tx.paths, img.spp),
            Some((&vals, tx.seconds)),
            Some((&im, img.seconds)),
            refs,
        )?);
    }
    Ok(points)
}
