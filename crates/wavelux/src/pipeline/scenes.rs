//! Scene sources of the command: `builtin:NAME` or a scene file (glTF or native TOML),
//! loaded and validated; `wavelux scenes` lists the built-ins.

use std::path::Path;

use anyhow::{Context, bail};
use wavelux::scene::{LoadOptions, MeshGrouping, Scene, builtin};

/// Loads `builtin:NAME` or a scene file (meshes grouped as `grouping` says),
/// validated; returns the scene and the stem of its output files (`cornell` for the
/// built-in Cornell box, else the name).
pub fn load_scene(source: &str, grouping: MeshGrouping) -> anyhow::Result<(Scene, String)> {
    if let Some(name) = source.strip_prefix("builtin:") {
        let scene = builtin::builtin(name).with_context(|| {
            format!(
                "unknown built-in scene {name:?}; `wavelux scenes` lists them: {}",
                builtin::BUILTIN_NAMES.join(", ")
            )
        })?;
        let stem = if name == "cornell-box" {
            "cornell".to_string()
        } else {
            name.to_string()
        };
        return Ok((scene, stem));
    }
    let path = Path::new(source);
    if !path.exists() {
        bail!("scene file {source:?} does not exist (use builtin:NAME for a built-in scene)");
    }
    let scene = wavelux::scene::load_with(path, &LoadOptions { grouping })
        .with_context(|| format!("cannot load {source:?}"))?;
    scene
        .validate(source)
        .with_context(|| format!("invalid scene {source:?}"))?;
    let stem = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "scene".into());
    Ok((scene, stem))
}

/// `wavelux scenes`: one line per built-in scene.
pub fn list_scenes() {
    println!(
        "{:<34} {:>8} {:>8} {:>10}",
        "built-in scene", "surfaces", "cameras", "area m²"
    );
    for name in builtin::BUILTIN_NAMES {
        if let Some(s) = builtin::builtin(name) {
            println!(
                "{:<34} {:>8} {:>8} {:>10.4}",
                format!("builtin:{name}"),
                s.surfaces.len(),
                s.cameras.len(),
                s.total_area()
            );
        }
    }
}

/// Whether a scene source names a glTF file (`.gltf`/`.glb`: `+y` up).
pub fn is_gltf(source: &str) -> bool {
    Path::new(source)
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb"))
}
