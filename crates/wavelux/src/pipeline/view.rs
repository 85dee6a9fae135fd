//! The view of the image: camera flags (`render --eye/--target`), a scene camera by
//! name, the scene's first camera, or an automatic camera framing the scene (or the
//! first medium of a scene without surfaces).

use anyhow::{Context, bail};
use glam::DVec3;
use wavelux::render::View;
use wavelux::scene::Scene;

use super::scenes::is_gltf;
use crate::cli::{CameraArgs, SolveArgs};

/// The view: camera flags, else the named or first scene camera, else an automatic one.
pub fn choose_view(scene: &Scene, a: &SolveArgs, cam: Option<&CameraArgs>) -> anyhow::Result<View> {
    let (w, h) = (a.width, a.height);
    if let Some(c) = cam {
        if let (Some(eye), Some(target)) = (&c.eye, &c.target) {
            let v = |x: &Vec<f64>, what: &str| -> anyhow::Result<DVec3> {
                match x.as_slice() {
                    [a, b, c] => Ok(DVec3::new(*a, *b, *c)),
                    _ => bail!("--{what} needs three comma-separated numbers x,y,z"),
                }
            };
            return View::look_at(
                v(eye, "eye")?,
                v(target, "target")?,
                v(&c.up, "up")?,
                c.fov.to_radians(),
                w,
                h,
            )
            .context("invalid look-at camera");
        }
        if let Some(name) = &c.camera {
            let camera = scene
                .cameras
                .iter()
                .find(|k| &k.name == name)
                .with_context(|| {
                    let names: Vec<&str> = scene.cameras.iter().map(|k| k.name.as_str()).collect();
                    format!("the scene has no camera {name:?} (cameras: {names:?})")
                })?;
            return View::new(camera, w, h).context("invalid scene camera");
        }
    }
    if let Some(camera) = scene.cameras.first() {
        return View::new(camera, w, h).context("invalid scene camera");
    }
    let up = wavelux::render::scene_up(scene, is_gltf(&a.scene));
    if scene.surfaces.is_empty()
        && let Some(m) = scene.media.first()
    {
        // A medium alone: look at its box from outside, along a diagonal.
        let (c, d) = (0.5 * (m.min + m.max), (m.max - m.min).length());
        let toward = [DVec3::Z, DVec3::X]
            .into_iter()
            .find(|t| t.dot(up).abs() < 0.9)
            .unwrap_or(DVec3::Z);
        let eye = c + (toward + 0.4 * up).normalize() * (1.5 * d);
        return View::look_at(eye, c, up, 40f64.to_radians(), w, h)
            .context("automatic camera of the medium");
    }
    Ok(View::new(&wavelux::render::auto_camera(scene, up)?, w, h)?)
}
