//! The files of a run: the linear EXR and tone-mapped PNG, the glTF and lightmap
//! exports of a wavelet solution, and the JSON result — each written to a temporary
//! file and renamed into place, so a failed run never destroys an older output.

use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use wavelux::render::{ToneMap, image::write_bytes_atomic};
use wavelux::scene::Scene;

use super::{Outcome, name_of};
use crate::cli::{MethodArg, SolveArgs};
use crate::report;

/// Path of the JSON result: `--json`, else `OUT/STEM.json`.
pub fn json_path(a: &SolveArgs, stem: &str) -> PathBuf {
    a.json
        .clone()
        .unwrap_or_else(|| a.out.join(format!("{stem}.json")))
}

/// Writes the image (EXR and PNG) and the exports (`--gltf`, `--lightmaps`); returns
/// the outputs' entry of the JSON (which names `json` but does not write it yet).
pub fn write_files(
    a: &SolveArgs,
    scene: &Scene,
    stem: &str,
    outcome: &Outcome,
    json: &Path,
) -> anyhow::Result<report::Outputs> {
    let mut outputs = report::Outputs {
        json: Some(json.display().to_string()),
        ..report::Outputs::default()
    };
    if let Some(img) = &outcome.image {
        let exr = a.out.join(format!("{stem}.exr"));
        let png = a.out.join(format!("{stem}.png"));
        img.write_exr(&exr)?;
        img.write_png(&png, ToneMap::Auto)?;
        outputs.exr = Some(exr.display().to_string());
        outputs.png = Some(png.display().to_string());
    }
    if let Some(sol) = &outcome.solution {
        let names: Vec<String> = scene.surfaces.iter().map(|s| s.name.clone()).collect();
        if let Some(g) = &a.gltf {
            wavelux::render::export::write_gltf(sol, &names, g, 2)
                .with_context(|| format!("glTF export to {g:?}"))?;
            outputs.gltf = Some(g.display().to_string());
        }
        if let Some(res) = a.lightmaps {
            let dir = lightmaps_dir(a, stem);
            wavelux::render::export::write_lightmaps(sol, &names, &dir, res)?;
            outputs.lightmaps = Some(dir.display().to_string());
        }
    } else if a.method == MethodArg::Meshless {
        // Written by the method itself (its field borrows its precomputation).
        outputs.gltf = a.gltf.as_ref().map(|g| g.display().to_string());
        outputs.lightmaps = a
            .lightmaps
            .map(|_| lightmaps_dir(a, stem).display().to_string());
    } else if a.method == MethodArg::GlobalCube && a.gltf.is_none() && a.lightmaps.is_none() {
        // Written by the method itself (they need its solution).
        outputs.volume_emission = Some(
            super::global_cube::raw_path(&a.out, stem)
                .display()
                .to_string(),
        );
        outputs.volume_slices = super::global_cube::slice_paths(&a.out, stem)
            .iter()
            .map(|p| p.display().to_string())
            .collect();
    } else if a.gltf.is_some() || a.lightmaps.is_some() {
        bail!(
            "--gltf and --lightmaps export a wavelet or meshless solution; --method {} has none",
            name_of(a.method)
        );
    }
    Ok(outputs)
}

/// The directory of `--lightmaps`: `OUT/STEM-lightmaps`.
pub fn lightmaps_dir(a: &SolveArgs, stem: &str) -> PathBuf {
    a.out.join(format!("{stem}-lightmaps"))
}

/// Writes the JSON result (pretty-printed) to `path`, creating its directory.
pub fn write_json(path: &Path, result: &report::Result) -> anyhow::Result<()> {
    let text = serde_json::to_string_pretty(result)?;
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create the directory of {path:?}"))?;
    }
    write_bytes_atomic(path, text.as_bytes())?;
    Ok(())
}
