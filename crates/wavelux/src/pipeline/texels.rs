//! `--texels DENSITY`: the radiosity *function* at a lightmap-like texel grid (issue 12
//! §1 (a)), written as `OUT/NAME.texels.json` so that `wavelux compare` can judge one
//! method's texels against another's (e.g. a path-traced reference's).
//!
//! The grid is `wavelux_render::TexelGrid` (centres of equal-area cells of every lit
//! side at `DENSITY` texels per scene unit², each with the area it stands for): the
//! same scene and density give the same texels whatever the method, so two files can be
//! compared point by point. A wavelet solution is evaluated at every texel (a probe ray
//! along the normal finds its element); `--method reference` path-traces
//! `--texel-paths` independent walks per texel and stores their standard errors.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use serde::{Deserialize, Serialize};
use wavelux::render::image::write_bytes_atomic;
use wavelux::render::{PathTracer, ReferenceOptions, SolutionField, Texel, TexelGrid};
use wavelux::scene::Scene;

use super::{Outcome, name_of};
use crate::cli::{MethodArg, SolveArgs};

/// Schema name of a texel file.
pub const SCHEMA: &str = "wavelux-texels";
/// Schema version of a texel file.
pub const VERSION: u32 = 1;

/// A texel file: the grid and one method's radiosity at every texel.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TexelFile {
    /// Always [`SCHEMA`].
    pub schema: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// The scene argument (`builtin:NAME` or a path).
    pub scene: String,
    /// The method that produced the values (`gather`, `shoot`, `reference`).
    pub method: String,
    /// Texels per scene unit².
    pub density: f64,
    /// Path-traced walks per texel (`reference` only).
    pub paths: Option<u64>,
    /// Texels whose probe ray did not find their own surface side (value zero).
    pub unresolved: usize,
    /// Wall time of the evaluation (s), not counting the solve.
    pub seconds: f64,
    /// The texels with their values.
    pub texels: Vec<TexelValue>,
}

/// One texel and the radiosity found there.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct TexelValue {
    /// Name of the scene surface.
    pub surface: String,
    /// The back side of a two-sided surface.
    pub back: bool,
    /// Position (scene units).
    pub point: [f64; 3],
    /// Unit normal of the lit side.
    pub normal: [f64; 3],
    /// Area the texel stands for (scene units²).
    pub area: f64,
    /// Emitted exitance of the side (W/m², RGB).
    pub emission: [f64; 3],
    /// Radiosity (W/m², RGB).
    pub radiosity: [f64; 3],
    /// Standard error of `radiosity` (Monte Carlo methods).
    pub std_error: Option<[f64; 3]>,
}

/// Path of the texel file: `OUT/STEM.texels.json`.
pub fn path(a: &SolveArgs, stem: &str) -> PathBuf {
    a.out.join(format!("{stem}.texels.json"))
}

/// Checks `--texels` and `--texel-paths` before anything is solved.
///
/// # Errors
/// A density that is not finite and positive, `--texel-paths 0`, or a method that
/// has neither a wavelet solution nor a path tracer (`meshless`).
pub fn check(a: &SolveArgs) -> anyhow::Result<()> {
    let Some(d) = a.texels else {
        return Ok(());
    };
    if !(d.is_finite() && d > 0.0) {
        bail!("--texels must be a positive density (texels per scene unit²), not {d}");
    }
    if a.texel_paths == 0 {
        bail!("--texel-paths must be >= 1");
    }
    if a.method == MethodArg::Meshless {
        bail!(
            "--texels needs a wavelet solution (--method gather or shoot) or --method \
reference, not --method meshless"
        );
    }
    Ok(())
}

/// Evaluates the outcome at the texel grid of `density` and writes the file to `out`.
///
/// # Errors
/// An invalid density (`TexelGrid::new`), a method without a solution or a path
/// tracer (`--method meshless`), or a failed write.
pub fn write(
    a: &SolveArgs,
    scene: &Scene,
    outcome: &Outcome,
    reference: &ReferenceOptions,
    density: f64,
    out: &Path,
) -> anyhow::Result<()> {
    let t = Instant::now();
    let grid = TexelGrid::new(scene, density).context("--texels")?;
    let (values, std_error, unresolved, paths) = if let Some(sol) = &outcome.solution {
        let field = SolutionField::new(sol)?;
        let v = grid.evaluate(&field);
        (v.values, None, v.unresolved, None)
    } else if a.method == MethodArg::Reference {
        let est = PathTracer::new(scene)?.texels(&grid, a.texel_paths, reference)?;
        (
            est.iter().map(|e| e.mean).collect(),
            Some(est.iter().map(|e| e.std_error).collect::<Vec<_>>()),
            0,
            Some(a.texel_paths),
        )
    } else {
        bail!(
            "--texels needs a wavelet solution (--method gather or shoot) or --method \
reference; --method {} has neither",
            name_of(a.method)
        );
    };
    let texels = grid
        .texels
        .iter()
        .enumerate()
        .map(|(i, t)| TexelValue {
            surface: scene.surfaces[t.surface].name.clone(),
            back: t.back,
            point: t.point,
            normal: t.normal,
            area: t.area,
            emission: t.emission,
            radiosity: values[i],
            std_error: std_error.as_ref().map(|s| s[i]),
        })
        .collect();
    let file = TexelFile {
        schema: SCHEMA.into(),
        version: VERSION,
        scene: a.scene.clone(),
        method: name_of(a.method),
        density,
        paths,
        unresolved,
        seconds: t.elapsed().as_secs_f64(),
        texels,
    };
    write_bytes_atomic(out, serde_json::to_string(&file)?.as_bytes())?;
    Ok(())
}

/// Reads a texel file, checking its schema.
///
/// # Errors
/// An unreadable file, invalid JSON, or another schema or version.
pub fn read(p: &Path) -> anyhow::Result<TexelFile> {
    let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {p:?}"))?;
    let f: TexelFile = serde_json::from_str(&text)
        .with_context(|| format!("{p:?} is not a wavelux texel file"))?;
    if f.schema != SCHEMA || f.version != VERSION {
        bail!(
            "{p:?}: schema {} version {} (expected {SCHEMA} version {VERSION})",
            f.schema,
            f.version
        );
    }
    Ok(f)
}

/// The grid of a texel file (surfaces numbered by first appearance; `prim` unused).
pub fn grid_of(f: &TexelFile) -> TexelGrid {
    let mut names: Vec<&str> = Vec::new();
    let texels = f
        .texels
        .iter()
        .map(|t| {
            let surface = match names.iter().position(|n| *n == t.surface) {
                Some(k) => k,
                None => {
                    names.push(&t.surface);
                    names.len() - 1
                }
            };
            Texel {
                surface,
                back: t.back,
                prim: 0,
                point: t.point,
                normal: t.normal,
                area: t.area,
                emission: t.emission,
            }
        })
        .collect();
    TexelGrid {
        density: f.density,
        texels,
    }
}
