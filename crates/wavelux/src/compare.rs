//! `wavelux compare A B`: error metrics of A against the reference B, for two JSON
//! results (per-surface radiosity, matched by name), two texel files (the radiosity
//! function at the same texel grid, `solve --texels`; issue 12 §1 (a)), two raw
//! emission grids of `--method global-cube` (GlobalCube eq. (35)'s `Q_square` and the
//! RMS difference; issue 14 §5) or two images (EXR/PNG).

use std::path::Path;

use anyhow::{Context, bail};
use serde::Serialize;
use wavelux::render::{Image, ToneMap, image::write_bytes_atomic};

use crate::cli::CompareArgs;
use crate::pipeline::{TexelFile, read_texels, texel_grid};
use crate::report;

/// Per-surface comparison.
#[derive(Debug, Serialize)]
struct SurfaceDiff {
    name: String,
    a: [f64; 3],
    b: [f64; 3],
    relative: f64,
    /// |a − b| / standard error of b (max over channels), when b has errors.
    z: Option<f64>,
}

/// Metrics of two results.
#[derive(Debug, Serialize)]
struct ResultMetrics {
    kind: &'static str,
    /// `Σ A |a − b|₁ / Σ A |b − E|₁` over the surfaces both have.
    relative_l1: f64,
    /// Largest per-surface relative difference `|a − b|₁ / |b − E|₁`.
    max_relative: f64,
    /// Largest |z| when the reference has standard errors.
    max_z: Option<f64>,
    surfaces: Vec<SurfaceDiff>,
}

#[derive(Debug, Serialize)]
struct ImageMetrics {
    kind: &'static str,
    #[serde(flatten)]
    metrics: wavelux::render::ErrorMetrics,
}

fn is_json(p: &Path) -> bool {
    p.extension().and_then(|e| e.to_str()) == Some("json")
}

fn is_raw(p: &Path) -> bool {
    p.extension().and_then(|e| e.to_str()) == Some("raw")
}

/// Metrics of two raw emission grids (`solve --method global-cube`'s
/// `STEM-emission.raw`, W/m³ per voxel and channel).
#[derive(Debug, Serialize)]
struct VolumeMetrics {
    kind: &'static str,
    /// Voxels per side.
    side: usize,
    /// GlobalCube eq. (35): `√(Σ (a − b)²) / count` over voxels and channels (W/m³).
    q_square: f64,
    /// Root-mean-square difference over voxels and channels (W/m³).
    rms: f64,
    /// `Σ |a − b| / Σ |b|` over voxels and channels.
    relative_l1: f64,
}

/// Reads a raw emission grid: `side³ × 3` little-endian `f32`, x fastest, RGB
/// interleaved (`wavelux_volume::VolumeSolution::emission_raw`).
fn read_raw(p: &Path) -> anyhow::Result<[ndarray::Array3<f64>; 3]> {
    let bytes = std::fs::read(p).with_context(|| format!("cannot read {p:?}"))?;
    let voxels = bytes.len() / 12;
    let side = (voxels as f64).cbrt().round() as usize;
    if !bytes.len().is_multiple_of(12) || voxels == 0 || side * side * side != voxels {
        bail!(
            "{p:?}: {} bytes is not an emission grid (side³ × 3 f32 values)",
            bytes.len()
        );
    }
    let mut out: [ndarray::Array3<f64>; 3] =
        std::array::from_fn(|_| ndarray::Array3::zeros((side, side, side)));
    for (i, b) in bytes.chunks_exact(4).enumerate() {
        let v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
        let (c, voxel) = (i % 3, i / 3);
        let (x, y, z) = (voxel % side, (voxel / side) % side, voxel / (side * side));
        if !v.is_finite() {
            bail!("{p:?}: voxel ({x}, {y}, {z}) channel {c} is {v}");
        }
        out[c][[z, y, x]] = f64::from(v);
    }
    Ok(out)
}

/// `a`'s emission grid against the reference `b`'s (same side).
fn compare_volumes(
    a: &[ndarray::Array3<f64>; 3],
    b: &[ndarray::Array3<f64>; 3],
) -> anyhow::Result<VolumeMetrics> {
    if a[0].dim() != b[0].dim() {
        bail!(
            "the emission grids have different sides ({} and {})",
            a[0].dim().0,
            b[0].dim().0
        );
    }
    let (mut num, mut den) = (0.0, 0.0);
    for (ca, cb) in a.iter().zip(b) {
        for (x, y) in ca.iter().zip(cb.iter()) {
            num += (x - y).abs();
            den += y.abs();
        }
    }
    Ok(VolumeMetrics {
        kind: "volume",
        side: a[0].dim().0,
        q_square: wavelux::volume::q_square(a, b)?,
        rms: wavelux::volume::rms(a, b)?,
        relative_l1: if den > 0.0 { num / den } else { num },
    })
}

fn read_result(p: &Path) -> anyhow::Result<report::Result> {
    let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {p:?}"))?;
    let r: report::Result =
        serde_json::from_str(&text).with_context(|| format!("{p:?} is not a wavelux result"))?;
    if r.schema != report::SCHEMA || r.version != report::VERSION {
        bail!(
            "{p:?}: schema {} version {} (expected {} version {})",
            r.schema,
            r.version,
            report::SCHEMA,
            report::VERSION
        );
    }
    Ok(r)
}

/// Runs `compare`.
pub fn run(c: &CompareArgs) -> anyhow::Result<()> {
    let text = match (is_json(&c.a), is_json(&c.b)) {
        (true, true) if is_texels(&c.a)? || is_texels(&c.b)? => {
            if c.map.is_some() {
                bail!("--map needs two images, not two texel files");
            }
            let m = compare_texels(&read_texels(&c.a)?, &read_texels(&c.b)?)?;
            if !c.quiet {
                print_texels(&m);
            }
            serde_json::to_string_pretty(&m)?
        }
        (true, true) => {
            if c.map.is_some() {
                bail!("--map needs two images, not two JSON results");
            }
            let m = compare_results(&read_result(&c.a)?, &read_result(&c.b)?)?;
            if !c.quiet {
                println!(
                    "surface-average radiosity: relative L1 {:.4}%, max per-surface {:.4}%{}",
                    100.0 * m.relative_l1,
                    100.0 * m.max_relative,
                    m.max_z
                        .map_or(String::new(), |z| format!(", max |z| {z:.2}"))
                );
                for s in &m.surfaces {
                    println!(
                        "  {:<28} {:>9.4}%{}",
                        s.name,
                        100.0 * s.relative,
                        s.z.map_or(String::new(), |z| format!("  z {z:.2}"))
                    );
                }
            }
            serde_json::to_string_pretty(&m)?
        }
        (false, false) if is_raw(&c.a) || is_raw(&c.b) => {
            if !(is_raw(&c.a) && is_raw(&c.b)) {
                bail!("compare two raw emission grids, not one and an image");
            }
            if c.map.is_some() {
                bail!("--map needs two images, not two emission grids");
            }
            let m = compare_volumes(&read_raw(&c.a)?, &read_raw(&c.b)?)?;
            if !c.quiet {
                println!(
                    "emission grid ({}³): Q_square {:.6e}, RMS {:.6e} W/m³, relative L1 {:.4}%",
                    m.side,
                    m.q_square,
                    m.rms,
                    100.0 * m.relative_l1
                );
            }
            serde_json::to_string_pretty(&m)?
        }
        (false, false) => {
            let a = Image::read(&c.a)?;
            let b = Image::read(&c.b)?;
            let metrics = a.metrics(&b)?;
            if let Some(map) = &c.map {
                if !(c.scale.is_finite() && c.scale > 0.0) {
                    bail!("--scale must be > 0");
                }
                a.error_map(&b, c.scale)?
                    .write_png(map, ToneMap::Exposure(1.0))?;
            }
            if !c.quiet {
                println!(
                    "image: L1 {:.6e}, relative L1 {:.4}%, RMSE {:.6e}, max {:.6e} (reference mean {:.6e})",
                    metrics.l1,
                    100.0 * metrics.relative_l1,
                    metrics.rmse,
                    metrics.max_abs,
                    metrics.reference_mean
                );
                if let Some(map) = &c.map {
                    println!("wrote {}", map.display());
                }
            }
            serde_json::to_string_pretty(&ImageMetrics {
                kind: "image",
                metrics,
            })?
        }
        _ => bail!("compare two JSON results, two emission grids or two images, not one of each"),
    };
    if let Some(p) = &c.json {
        write_bytes_atomic(p, text.as_bytes())?;
    }
    Ok(())
}

fn compare_results(a: &report::Result, b: &report::Result) -> anyhow::Result<ResultMetrics> {
    let (mut num, mut den, mut max_rel) = (0.0, 0.0, 0.0f64);
    let mut max_z: Option<f64> = None;
    let mut surfaces = Vec::new();
    for sb in &b.surfaces {
        let Some(sa) = a.surfaces.iter().find(|s| s.name == sb.name) else {
            continue;
        };
        let d: f64 = (0..3)
            .map(|c| (sa.radiosity[c] - sb.radiosity[c]).abs())
            .sum();
        // Relative to the reflected radiosity B − E (emission is exact for every method).
        let n: f64 = (0..3)
            .map(|c| (sb.radiosity[c] - sb.emission[c]).abs())
            .sum();
        num += sb.area * d;
        den += sb.area * n;
        let rel = if n > 0.0 { d / n } else { d };
        max_rel = max_rel.max(rel);
        let z = sb.std_error.map(|se| {
            (0..3)
                .filter(|&c| se[c] > 0.0)
                .map(|c| (sa.radiosity[c] - sb.radiosity[c]).abs() / se[c])
                .fold(0.0f64, f64::max)
        });
        if let Some(z) = z {
            max_z = Some(max_z.unwrap_or(0.0).max(z));
        }
        surfaces.push(SurfaceDiff {
            name: sb.name.clone(),
            a: sa.radiosity,
            b: sb.radiosity,
            relative: rel,
            z,
        });
    }
    if surfaces.is_empty() {
        bail!("the two results have no surface names in common");
    }
    Ok(ResultMetrics {
        kind: "result",
        relative_l1: if den > 0.0 { num / den } else { num },
        max_relative: max_rel,
        max_z,
        surfaces,
    })
}

/// True if `p` is a JSON file whose `schema` is the texel file's.
fn is_texels(p: &Path) -> anyhow::Result<bool> {
    let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {p:?}"))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{p:?} is not JSON"))?;
    Ok(v.get("schema").and_then(|s| s.as_str()) == Some(crate::pipeline::TEXEL_SCHEMA))
}

/// The texel metric of one surface side.
#[derive(Debug, Serialize)]
struct TexelSide {
    name: String,
    back: bool,
    texels: usize,
    /// `Σ A |a − b|₁ / Σ A |b − E|₁` over the side's texels.
    relative_l1: f64,
}

/// Metrics of two texel files.
#[derive(Debug, Serialize)]
struct TexelComparison {
    kind: &'static str,
    /// Area-weighted relative L1 of the reflected radiosity over every texel, the
    /// expected score of an exact answer against `B`'s noise (`noise_floor`, when `B`
    /// has standard errors), and the largest per-texel relative error.
    #[serde(flatten)]
    metrics: wavelux::render::TexelMetrics,
    /// Texels of `A` whose probe ray missed their own surface side (value zero).
    unresolved: usize,
    /// Per surface side.
    sides: Vec<TexelSide>,
}

fn print_texels(m: &TexelComparison) {
    println!(
        "texels: relative L1 {:.4}%{}, max per-texel {:.4}% ({} texels, {} unresolved)",
        100.0 * m.metrics.relative_l1,
        m.metrics.noise_floor.map_or(String::new(), |f| format!(
            " (reference noise floor {:.4}%)",
            100.0 * f
        )),
        100.0 * m.metrics.max_relative,
        m.metrics.texels,
        m.unresolved
    );
    for s in &m.sides {
        println!(
            "  {:<28} {:<5} {:>6} texels {:>9.4}%",
            s.name,
            if s.back { "back" } else { "front" },
            s.texels,
            100.0 * s.relative_l1
        );
    }
}

/// `a`'s texels against the reference `b`'s: both must hold the same grid (same scene
/// and density: every texel at the same point, side and area).
fn compare_texels(a: &TexelFile, b: &TexelFile) -> anyhow::Result<TexelComparison> {
    if a.texels.len() != b.texels.len() {
        bail!(
            "the texel files hold different grids ({} and {} texels); write both for the \
same scene with the same --texels density",
            a.texels.len(),
            b.texels.len()
        );
    }
    let scale = b
        .texels
        .iter()
        .flat_map(|t| t.point)
        .fold(0.0f64, |m, x| m.max(x.abs()))
        .max(f64::MIN_POSITIVE);
    for (i, (x, y)) in a.texels.iter().zip(&b.texels).enumerate() {
        let far = (0..3).any(|c| (x.point[c] - y.point[c]).abs() > 1e-9 * scale);
        if x.surface != y.surface || x.back != y.back || far {
            bail!(
                "the texel files hold different grids (texel {i}: {:?} at {:?} and {:?} at \
{:?}); write both for the same scene with the same --texels density",
                x.surface,
                x.point,
                y.surface,
                y.point
            );
        }
    }
    let grid = texel_grid(b);
    let va: Vec<[f64; 3]> = a.texels.iter().map(|t| t.radiosity).collect();
    let vb: Vec<[f64; 3]> = b.texels.iter().map(|t| t.radiosity).collect();
    let se: Option<Vec<[f64; 3]>> = b.texels.iter().map(|t| t.std_error).collect();
    let metrics = grid.compare(&va, &vb, se.as_deref())?;
    let mut sides: Vec<TexelSide> = Vec::new();
    let mut sums: Vec<(f64, f64)> = Vec::new();
    for (i, t) in b.texels.iter().enumerate() {
        let k = match sides
            .iter()
            .position(|s| s.name == t.surface && s.back == t.back)
        {
            Some(k) => k,
            None => {
                sides.push(TexelSide {
                    name: t.surface.clone(),
                    back: t.back,
                    texels: 0,
                    relative_l1: 0.0,
                });
                sums.push((0.0, 0.0));
                sides.len() - 1
            }
        };
        sides[k].texels += 1;
        for c in 0..3 {
            sums[k].0 += t.area * (va[i][c] - vb[i][c]).abs();
            sums[k].1 += t.area * (vb[i][c] - t.emission[c]).abs();
        }
    }
    for (s, (num, den)) in sides.iter_mut().zip(sums) {
        s.relative_l1 = if den > 0.0 { num / den } else { num };
    }
    Ok(TexelComparison {
        kind: "texels",
        metrics,
        unresolved: a.unresolved,
        sides,
    })
}
