//! `relight`: precomputed meshless direct-to-indirect transfer (Meshless §3.3) lighting
//! a scene frame by frame. The transfer is precomputed once (or read from
//! `--transfer`); each frame's punctual lights (`--light`, or the frames of `--path`,
//! or the scene's own lights) replace the scene's, its area emitters stay; per frame:
//! direct irradiance at the sender points, `e = P†E←`, `i = S·e`, the full and the
//! indirect image, optional lightmaps and baked glTF, and the frame's entry of the
//! JSON (times in ms, active senders, per-surface full and indirect means).

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{Context, bail};
use glam::DVec3;
use serde::Deserialize;
use serde_json::json;
use wavelux::meshless::direct::validate_lights;
use wavelux::meshless::{DirectLighting, Relighter, SceneSurfaces};
use wavelux::render::export::{field_surface_averages, write_field_gltf, write_field_lightmaps};
use wavelux::render::{Component, IndirectSource, MeshlessField, RenderOptions, ToneMap};
use wavelux::scene::{Light, Rgb, Scene};

use super::{
    check_image_options, load_scene, mesh_grouping, meshless, output, secs, thread_pool, view,
    warnings,
};
use crate::cli::RelightArgs;
use crate::progress;

/// One frame of `--path`.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct FrameSpec {
    /// Light specifications (`--light` syntax).
    lights: Vec<String>,
}

/// Runs `relight` (module docs).
pub fn run(r: &RelightArgs) -> anyhow::Result<()> {
    let a = &r.solve;
    let t_start = Instant::now();
    let threads = thread_pool(a.threads)?;
    check_image_options(a)?;
    let (scene, stem) = load_scene(&a.scene, mesh_grouping(a))?;
    // The loader's warnings and what the meshless method does not model (Ward lobes,
    // media, textures, emitters it cannot sample), as for `solve`, each once: stderr,
    // JSON, `--strict`.
    let query = SceneSurfaces::new(&scene).context("meshless scene query")?;
    let mut warned = warnings::from_scene(&scene);
    warned.extend(warnings::unmodelled(&scene, "meshless", &a.scene));
    warned.extend(meshless::unsampled_emitters(&query, &a.scene));
    let device = super::device::choose(a.device, Ok(()), &mut warned)?;
    warnings::strict(a.strict, &warned)?;
    warnings::print(&warned);
    let frames = frames(r, &scene)?;
    let config = meshless::config(a)?;
    let view = if a.no_image {
        None
    } else {
        Some(view::choose_view(&scene, a, Some(&r.camera))?)
    };
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create the output directory {:?}", a.out))?;
    let show = progress::enabled(a.quiet);

    let t = Instant::now();
    let (pre, loaded) = meshless::precompute(&scene, a, &config, show)?;
    let precompute_s = secs(t.elapsed());
    let relighter = Relighter::new(&pre, super::device::DeviceTransfer::new(&device))?;

    let mut out_frames = Vec::new();
    for (k, lights) in frames.iter().enumerate() {
        validate_lights(lights).with_context(|| format!("frame {k}"))?;
        let mut parts = vec![DirectLighting::Lights(lights.clone())];
        if query.has_emitters() {
            parts.push(DirectLighting::Emitters {
                samples: a.meshless.emitter_samples,
                seed: a.seed,
            });
        }
        let direct = DirectLighting::Sum(parts);
        let t = Instant::now();
        let indirect = relighter
            .relight_with(&query, &direct)
            .with_context(|| format!("frame {k}"))?;
        let relight_ms = t.elapsed().as_secs_f64() * 1e3;
        let full = MeshlessField::new(
            &query,
            IndirectSource::Hierarchical(&indirect),
            direct,
            Component::Full,
        );
        let ind = full.with_component(Component::Indirect);
        let full_avg = field_surface_averages(&full, &scene, meshless::AVERAGE_SAMPLES)?;
        let ind_avg = field_surface_averages(&ind, &scene, meshless::AVERAGE_SAMPLES)?;
        let name = format!("{stem}.relight.{k:03}");
        let mut files = serde_json::Map::new();
        let mut render_s = 0.0;
        if let Some(view) = &view {
            let t = Instant::now();
            for (field, suffix) in [(&full, ""), (&ind, ".indirect")] {
                let pb = progress::bar(show, view.height as u64, "rendering");
                let (img, _) = wavelux::render::render(
                    field,
                    view,
                    &RenderOptions {
                        spp: a.spp,
                        gather: 0,
                        direct: 0,
                        seed: a.seed,
                    },
                    &|n| pb.inc(n),
                )?;
                pb.finish_and_clear();
                let exr = a.out.join(format!("{name}{suffix}.exr"));
                let png = a.out.join(format!("{name}{suffix}.png"));
                img.write_exr(&exr)?;
                img.write_png(&png, ToneMap::Auto)?;
                let key = if suffix.is_empty() {
                    "full"
                } else {
                    "indirect"
                };
                files.insert(
                    key.into(),
                    json!({"exr": exr.display().to_string(), "png": png.display().to_string()}),
                );
            }
            render_s = secs(t.elapsed());
        }
        if let Some(g) = &a.gltf {
            let path = frame_path(g, k);
            write_field_gltf(&full, &scene, &path)
                .with_context(|| format!("glTF export to {path:?}"))?;
            files.insert("gltf".into(), json!(path.display().to_string()));
        }
        if let Some(res) = a.lightmaps {
            let dir = output::lightmaps_dir(a, &name);
            write_field_lightmaps(&full, &scene, &dir, res)?;
            files.insert("lightmaps".into(), json!(dir.display().to_string()));
        }
        let surfaces: Vec<_> = scene
            .surfaces
            .iter()
            .enumerate()
            .map(|(i, s)| {
                json!({"name": s.name, "area": s.shape.area(), "radiosity": full_avg[i], "indirect": ind_avg[i]})
            })
            .collect();
        let lights_json: Vec<_> = lights.iter().map(light_json).collect();
        if !a.quiet {
            println!(
                "  frame {k:3}  {} light(s): direct {:.2} ms, pull-push {:.2} ms, S·e {:.2} ms ({} active senders), relight {:.2} ms",
                lights.len(),
                indirect.times.direct_ms,
                indirect.times.pull_push_ms,
                indirect.times.transport_ms,
                indirect.times.active_senders,
                relight_ms
            );
        }
        out_frames.push(json!({
            "lights": lights_json,
            "times_ms": indirect.times,
            "relight_ms": relight_ms,
            "render_s": render_s,
            "outputs": files,
            "surfaces": surfaces,
        }));
    }
    let json_path = a
        .json
        .clone()
        .unwrap_or_else(|| a.out.join(format!("{stem}.relight.json")));
    let result = json!({
        "schema": "wavelux-relight",
        "version": 1,
        "scene": {"source": a.scene, "name": scene.name, "surfaces": scene.surfaces.len()},
        "config": config,
        "threads": threads,
        "seed": a.seed,
        "transfer_loaded": loaded,
        "backend": relighter.backend_name(),
        "device": device.info(),
        "precompute": super::meshless::reported_stats(&pre),
        "precompute_s": precompute_s,
        "runtime_bytes": pre.runtime_bytes(),
        "warnings": warned,
        "frames": out_frames,
        "total_s": secs(t_start.elapsed()),
    });
    let text = serde_json::to_string_pretty(&result)?;
    wavelux::render::image::write_bytes_atomic(&json_path, text.as_bytes())?;
    if !a.quiet {
        let pts: usize = pre.stats.points_per_level.iter().sum();
        println!(
            "wavelux relight — {} ({}): {} frame(s), {pts} points, {} links in S, precompute {precompute_s:.2} s{}",
            scene.name,
            a.scene,
            frames.len(),
            pre.s.nnz(),
            if loaded { " (transfer loaded)" } else { "" }
        );
        println!("  wrote       {}", json_path.display());
    }
    Ok(())
}

/// `PATH` with the frame number before its extension (`a.gltf` → `a.007.gltf`).
fn frame_path(p: &Path, k: usize) -> PathBuf {
    let stem = p
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let ext = p
        .extension()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "gltf".into());
    p.with_file_name(format!("{stem}.{k:03}.{ext}"))
}

/// The frames: those of `--path`, else one of the `--light`s, else one of the
/// scene's own lights.
fn frames(r: &RelightArgs, scene: &Scene) -> anyhow::Result<Vec<Vec<Light>>> {
    if let Some(p) = &r.path {
        if !r.lights.is_empty() {
            bail!("--light and --path exclude each other");
        }
        let text = std::fs::read_to_string(p).with_context(|| format!("cannot read {p:?}"))?;
        let specs: Vec<FrameSpec> = serde_json::from_str(&text).with_context(|| {
            format!("{p:?}: expected a JSON array of {{\"lights\": [\"spot:...\", ...]}}")
        })?;
        if specs.is_empty() {
            bail!("{p:?}: no frames");
        }
        return specs
            .iter()
            .enumerate()
            .map(|(k, f)| {
                f.lights
                    .iter()
                    .enumerate()
                    .map(|(i, s)| parse_light(s, i).with_context(|| format!("{p:?}: frame {k}")))
                    .collect()
            })
            .collect();
    }
    if !r.lights.is_empty() {
        let lights = r
            .lights
            .iter()
            .enumerate()
            .map(|(i, s)| parse_light(s, i).context("--light"))
            .collect::<anyhow::Result<Vec<_>>>()?;
        return Ok(vec![lights]);
    }
    if scene.lights.is_empty() {
        bail!(
            "scene {:?} has no punctual lights: give --light or --path",
            scene.name
        );
    }
    Ok(vec![scene.lights.clone()])
}

/// Parses `spot:pos=x,y,z,dir=x,y,z,angle=DEG[,inner=DEG],rgb=R[,G,B]` or
/// `point:pos=x,y,z,rgb=R[,G,B]` (intensity in W/sr; angles: cone half-angles in
/// degrees, `inner` defaults to `angle`, a hard edge). The light is named `light I`.
pub fn parse_light(spec: &str, index: usize) -> anyhow::Result<Light> {
    let (kind, rest) = spec.split_once(':').with_context(|| {
        format!("light {spec:?}: expected KIND:key=value,... (KIND point or spot)")
    })?;
    let mut keys: Vec<(String, Vec<f64>)> = Vec::new();
    for tok in rest.split(',').map(str::trim) {
        let (key, val) = match tok.split_once('=') {
            Some((k, v)) => {
                if keys.iter().any(|(q, _)| q == k) {
                    bail!("light {spec:?}: {k} given twice");
                }
                keys.push((k.to_string(), Vec::new()));
                (k.to_string(), v)
            }
            None => match keys.last() {
                Some((k, _)) => (k.clone(), tok),
                None => bail!("light {spec:?}: expected key=value, got {tok:?}"),
            },
        };
        let v: f64 = val
            .parse()
            .with_context(|| format!("light {spec:?}: {key}: {val:?} is not a number"))?;
        if let Some(entry) = keys.last_mut() {
            entry.1.push(v);
        }
    }
    let get = |k: &str| keys.iter().find(|(q, _)| q == k).map(|(_, v)| v.as_slice());
    let allowed: &[&str] = match kind {
        "point" => &["pos", "rgb"],
        "spot" => &["pos", "dir", "angle", "inner", "rgb"],
        other => bail!("light {spec:?}: unknown kind {other:?} (point or spot)"),
    };
    if let Some((k, _)) = keys.iter().find(|(k, _)| !allowed.contains(&k.as_str())) {
        bail!(
            "light {spec:?}: unknown key {k:?} for a {kind} light (keys: {})",
            allowed.join(", ")
        );
    }
    let vec3 = |k: &str| -> anyhow::Result<DVec3> {
        match get(k) {
            Some([x, y, z]) => Ok(DVec3::new(*x, *y, *z)),
            Some(_) => bail!("light {spec:?}: {k} needs three numbers x,y,z"),
            None => bail!("light {spec:?}: {k}= is missing"),
        }
    };
    let one = |k: &str| -> anyhow::Result<Option<f64>> {
        match get(k) {
            Some([v]) => Ok(Some(*v)),
            Some(_) => bail!("light {spec:?}: {k} needs one number"),
            None => Ok(None),
        }
    };
    let rgb = match get("rgb") {
        Some([v]) => [*v; 3],
        Some([r, g, b]) => [*r, *g, *b],
        Some(_) => bail!("light {spec:?}: rgb needs one or three numbers"),
        None => bail!("light {spec:?}: rgb= is missing"),
    };
    let name = format!("light {index}");
    let pos = vec3("pos")?;
    let light = match kind {
        "point" => Light::point(name, pos, Rgb(rgb)),
        _ => {
            let outer =
                one("angle")?.with_context(|| format!("light {spec:?}: angle= is missing"))?;
            let inner = one("inner")?.unwrap_or(outer);
            Light::spot(
                name,
                pos,
                vec3("dir")?,
                inner.to_radians(),
                outer.to_radians(),
                Rgb(rgb),
            )
        }
    };
    validate_lights(std::slice::from_ref(&light)).with_context(|| format!("light {spec:?}"))?;
    Ok(light)
}

/// A light in the JSON.
fn light_json(l: &Light) -> serde_json::Value {
    let kind = match l.kind {
        wavelux::scene::LightKind::Point => json!({"point": {}}),
        wavelux::scene::LightKind::Spot {
            direction,
            inner,
            outer,
        } => json!({"spot": {
            "direction": direction.to_array(),
            "inner_deg": inner.to_degrees(),
            "outer_deg": outer.to_degrees(),
        }}),
        _ => json!({"other": {}}),
    };
    json!({"name": l.name, "position": l.position.to_array(), "intensity": l.intensity.0, "kind": kind})
}
