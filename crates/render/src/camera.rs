//! Views: a camera (glTF 2.0 §3.10 perspective or orthographic, or an explicit
//! look-at) bound to an image size, and the primary rays through its pixels.
//!
//! Pixel `(x, y)` covers `[x, x+1] × [y, y+1]` in raster space, `y` growing downwards;
//! a sample at offset `(jx, jy) ∈ [0,1)²` inside it goes through the image-plane point
//! `((x+jx)/w·2−1)·tan(yfov/2)·aspect` right and `(1−(y+jy)/h·2)·tan(yfov/2)` up.
//!
//! Scenes without a camera get an automatic one ([`auto_camera`]) oriented by the
//! scene's up direction ([`scene_up`]).

use glam::DVec3;
use wavelux_geometry::{Accel, Ray};
use wavelux_scene::{Camera, DefaultValue, Projection, Scene, Sidedness};

use crate::{RenderError, invalid};

/// A camera bound to an image size.
#[derive(Debug, Clone, PartialEq)]
pub struct View {
    /// Eye position.
    pub position: DVec3,
    /// Unit viewing direction.
    pub forward: DVec3,
    /// Unit up direction (orthogonal to `forward`).
    pub up: DVec3,
    /// Unit right direction `forward × up`.
    pub right: DVec3,
    /// Projection.
    pub projection: Projection,
    /// Image width in pixels.
    pub width: usize,
    /// Image height in pixels.
    pub height: usize,
}

impl View {
    /// Binds a scene camera to an image of `width × height` pixels. A perspective
    /// camera without an aspect ratio uses the image's; with one, the vertical field
    /// of view is kept and the horizontal extent follows the image (no distortion).
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for a zero size or a degenerate camera frame.
    pub fn new(camera: &Camera, width: usize, height: usize) -> Result<Self, RenderError> {
        if width == 0 || height == 0 {
            return Err(invalid("image size", "width and height must be >= 1"));
        }
        let forward = camera
            .forward
            .try_normalize()
            .ok_or_else(|| invalid("camera", "zero forward direction"))?;
        let up = (camera.up - forward * forward.dot(camera.up))
            .try_normalize()
            .ok_or_else(|| invalid("camera", "up parallel to forward"))?;
        if !camera.position.is_finite() {
            return Err(invalid("camera", "non-finite position"));
        }
        match camera.projection {
            Projection::Perspective { yfov, .. } => {
                if !(yfov.is_finite() && yfov > 0.0 && yfov < std::f64::consts::PI) {
                    return Err(invalid("camera", format!("yfov {yfov} outside (0, π)")));
                }
            }
            Projection::Orthographic { xmag, ymag } => {
                if !(xmag.is_finite() && ymag.is_finite() && xmag > 0.0 && ymag > 0.0) {
                    return Err(invalid("camera", "orthographic magnifications must be > 0"));
                }
            }
            #[allow(unreachable_patterns)]
            _ => return Err(invalid("camera", "unsupported projection")),
        }
        Ok(Self {
            position: camera.position,
            forward,
            up,
            right: forward.cross(up),
            projection: camera.projection,
            width,
            height,
        })
    }

    /// A perspective look-at view (`yfov` in radians).
    ///
    /// # Errors
    /// [`RenderError::Invalid`] for degenerate directions, `yfov ∉ (0, π)` or a zero size.
    pub fn look_at(
        eye: DVec3,
        target: DVec3,
        up: DVec3,
        yfov: f64,
        width: usize,
        height: usize,
    ) -> Result<Self, RenderError> {
        let cam = Camera::look_at("look-at", eye, target, up, yfov, None)
            .ok_or_else(|| invalid("look-at camera", "degenerate eye/target/up or yfov"))?;
        Self::new(&cam, width, height)
    }

    /// The primary ray through raster point `(x + jx, y + jy)`.
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        let w = self.width as f64;
        let h = self.height as f64;
        let sx = x / w * 2.0 - 1.0;
        let sy = 1.0 - y / h * 2.0;
        let (origin, dir) = match self.projection {
            Projection::Orthographic { xmag, ymag } => (
                self.position + self.right * (sx * xmag) + self.up * (sy * ymag),
                self.forward,
            ),
            Projection::Perspective { yfov, .. } => {
                let th = (0.5 * yfov).tan();
                let aspect = w / h;
                (
                    self.position,
                    self.forward + self.right * (sx * th * aspect) + self.up * (sy * th),
                )
            }
            #[allow(unreachable_patterns)]
            _ => (self.position, self.forward),
        };
        // The frame is orthonormal and finite (checked in `new`), so the direction is
        // non-zero and this cannot fail.
        Ray::new(origin, dir).unwrap_or(Ray {
            origin: self.position,
            dir: self.forward,
        })
    }
}

/// The key of a scene's `[defaults]` table that states its up direction: `"+x"`,
/// `"-x"`, `"+y"`, `"-y"`, `"+z"`, `"-z"` (sign optional, case-insensitive) or three
/// comma-separated numbers.
pub const UP_KEY: &str = "up";

/// Parses an up direction as accepted under [`UP_KEY`] (a unit vector).
pub fn parse_up(text: &str) -> Option<DVec3> {
    let t = text.trim().to_ascii_lowercase();
    let (sign, axis) = match t.strip_prefix('-') {
        Some(rest) => (-1.0, rest),
        None => (1.0, t.strip_prefix('+').unwrap_or(&t)),
    };
    let v = match axis {
        "x" => DVec3::X,
        "y" => DVec3::Y,
        "z" => DVec3::Z,
        _ => {
            let c: Vec<f64> = t
                .split(',')
                .map(|x| x.trim().parse::<f64>())
                .collect::<Result<_, _>>()
                .ok()?;
            return match c.as_slice() {
                [x, y, z] => DVec3::new(*x, *y, *z).try_normalize(),
                _ => None,
            };
        }
    };
    Some(sign * v)
}

/// The up direction of a scene, by the first rule that applies:
/// 1. the scene states it: `defaults["up"]` (see [`UP_KEY`]);
/// 2. the scene came from glTF (`from_gltf`): `+y` (glTF 2.0 §3.4: "+Y is up");
/// 3. its planar emitters face one way: lights hang from ceilings, so if the
///    area-weighted normal of every emitting side of a planar primitive has a
///    coordinate whose magnitude is at least half the emitting area, up is the
///    opposite of that axis (the Cornell box's light faces `−y`: up `+y`; Ziegler's
///    emitters at `z = 1` face `−z`: up `+z`);
/// 4. otherwise `+y` (glTF's convention).
pub fn scene_up(scene: &Scene, from_gltf: bool) -> DVec3 {
    if let Some(DefaultValue::Str(s)) = scene.defaults.get(UP_KEY)
        && let Some(up) = parse_up(s)
    {
        return up;
    }
    if from_gltf {
        return DVec3::Y;
    }
    let emits = |m: usize| {
        scene
            .materials
            .get(m)
            .is_some_and(|m| m.emission.0.iter().any(|&e| e > 0.0))
    };
    let (mut sum, mut area) = (DVec3::ZERO, 0.0);
    for s in &scene.surfaces {
        let front = emits(s.material);
        let back = matches!(s.sides, Sidedness::TwoSided { back } if emits(back));
        if !front && !back {
            continue;
        }
        let Ok(prims) = s.shape.primitives(&scene.name, &s.name) else {
            continue;
        };
        for p in prims.iter().filter(|p| p.is_planar()) {
            let n = p.normal(glam::DVec2::splat(0.5)) * p.area();
            for (lit, sign) in [(front, 1.0), (back, -1.0)] {
                if lit {
                    sum += sign * n;
                    area += p.area();
                }
            }
        }
    }
    let k = sum.abs().max_position();
    if area > 0.0 && sum[k].abs() >= 0.5 * area {
        let mut up = DVec3::ZERO;
        up[k] = -sum[k].signum();
        return up;
    }
    DVec3::Y
}

/// An automatic camera for a scene without one, upright along `up`. The camera looks
/// horizontally along the first of `−z`, `+y`, `−x` not parallel to `up` (so `+y`-up
/// scenes are seen from `+z` like glTF's default camera, `+z`-up scenes from `−y`). If
/// rays from a point near the bounding box's near side hit front faces in all six axis
/// directions the scene is an enclosure and the camera stands there (70° field of
/// view) looking across and slightly down; otherwise it looks at the centre of the
/// bounding box from outside, from the front, right and above (45°).
///
/// # Errors
/// [`RenderError::Scene`] for a scene without valid geometry;
/// [`RenderError::Invalid`] for a zero `up`.
pub fn auto_camera(scene: &Scene, up: DVec3) -> Result<Camera, RenderError> {
    let up = up
        .try_normalize()
        .ok_or_else(|| invalid("up", "zero vector"))?;
    let prims: Vec<_> = scene
        .primitives(&scene.name)
        .map_err(|e| RenderError::Scene(e.to_string()))?
        .into_iter()
        .map(|(_, p)| p)
        .collect();
    let accel = Accel::build(prims).map_err(|e| RenderError::Scene(e.to_string()))?;
    let b = accel.bounds();
    let (c, size) = (b.center(), b.diagonal());
    let d = size.length().max(1e-12);
    // Horizontal direction from the scene towards the eye.
    let toward = [DVec3::Z, DVec3::NEG_Y, DVec3::X]
        .into_iter()
        .find(|t| t.dot(up).abs() < 0.9)
        .map(|t| (t - up * up.dot(t)).normalize())
        .unwrap_or(DVec3::Z);
    let right = up.cross(toward);
    let extent = |dir: DVec3| (size * dir).abs().element_sum();
    let (ext_t, ext_up) = (extent(toward), extent(up));
    let inside_eye = c + toward * (0.45 * ext_t) + up * (0.1 * ext_up);
    // Explicit axis constants: negating `X` gives `(−1, −0, −0)`, whose signed zeros
    // make the BVH traversal miss.
    let enclosed = [
        DVec3::X,
        DVec3::NEG_X,
        DVec3::Y,
        DVec3::NEG_Y,
        DVec3::Z,
        DVec3::NEG_Z,
    ]
    .into_iter()
    .all(|dir| {
        Ray::new(inside_eye, dir)
            .ok()
            .and_then(|r| accel.closest_hit(&r, 0.0, f64::INFINITY))
            .is_some_and(|h| h.front)
    });
    let (eye, target, fov) = if enclosed {
        (
            inside_eye,
            c - toward * (0.5 * ext_t) - up * (0.15 * ext_up),
            70f64,
        )
    } else {
        (
            c + (0.35 * right + toward + 0.8 * up).normalize() * (1.2 * d),
            c,
            45f64,
        )
    };
    Camera::look_at("auto", eye, target, up, fov.to_radians(), None)
        .ok_or_else(|| invalid("automatic camera", "degenerate placement"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_is_forward_and_corners_span_the_fov() {
        let v = View::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 1.0, 64, 32).unwrap();
        let c = v.ray(32.0, 16.0);
        assert!((c.dir - DVec3::Z).length() < 1e-12);
        let top = v.ray(32.0, 0.0);
        assert!((top.dir.angle_between(DVec3::Z) - 0.5).abs() < 1e-12);
        assert!(top.dir.y > 0.0);
        // The right edge is at tan(yfov/2)·aspect.
        let r = v.ray(64.0, 16.0);
        assert!(((r.dir.x / r.dir.z).abs() - 2.0 * 0.5f64.tan()).abs() < 1e-12);
    }

    #[test]
    fn scene_up_follows_statement_gltf_and_emitters() {
        use wavelux_scene::builtin;
        // The Cornell box's light faces −y, Ziegler's emitters face −z, the Ziegler
        // box's ceiling light faces −y.
        assert_eq!(scene_up(&builtin::cornell_box(), false), DVec3::Y);
        assert_eq!(scene_up(&builtin::occluded(), false), DVec3::Z);
        assert_eq!(
            scene_up(
                &builtin::builtin("ziegler-box-occluded-high-a").unwrap(),
                false
            ),
            DVec3::Y
        );
        // glTF is +y up whatever the lights do.
        assert_eq!(scene_up(&builtin::occluded(), true), DVec3::Y);
        // Every face of the furnace emits: no preferred side, glTF's +y.
        let furnace = builtin::white_furnace(1.0, 0.5).unwrap();
        assert_eq!(scene_up(&furnace, false), DVec3::Y);
        // A stated up wins.
        let mut s = builtin::occluded();
        s.defaults
            .insert(UP_KEY.into(), DefaultValue::Str("-X".into()));
        assert_eq!(scene_up(&s, true), DVec3::NEG_X);
        s.defaults
            .insert(UP_KEY.into(), DefaultValue::Str("0, 0, 2".into()));
        assert_eq!(scene_up(&s, true), DVec3::Z);
        assert_eq!(parse_up("w"), None);
        assert_eq!(parse_up("1,2"), None);
    }

    #[test]
    fn auto_camera_is_upright_and_sees_the_scene() {
        use wavelux_scene::builtin;
        for (name, inside) in [
            ("ziegler-occluded", false),
            ("ziegler-box-occluded-high-a", true),
            ("white-furnace", true),
        ] {
            let s = builtin::builtin(name).unwrap();
            let up = scene_up(&s, false);
            let cam = auto_camera(&s, up).unwrap();
            // Upright: the camera's up has a positive component along the scene's up
            // and its right vector is horizontal.
            assert!(cam.up.dot(up) > 0.5, "{name}: up {:?}", cam.up);
            assert!(cam.right().dot(up).abs() < 1e-12, "{name}");
            let pts: Vec<DVec3> = s
                .primitives(name)
                .unwrap()
                .iter()
                .flat_map(|(_, p)| [p.eval(glam::DVec2::ZERO), p.eval(glam::DVec2::ONE)])
                .collect();
            let lo = pts.iter().fold(DVec3::INFINITY, |a, p| a.min(*p));
            let hi = pts.iter().fold(DVec3::NEG_INFINITY, |a, p| a.max(*p));
            let in_box = cam.position.cmpge(lo).all() && cam.position.cmple(hi).all();
            assert_eq!(in_box, inside, "{name}: eye {:?}", cam.position);
            // The centre ray hits the scene.
            let v = View::new(&cam, 8, 8).unwrap();
            let acc = Accel::build(
                s.primitives(name)
                    .unwrap()
                    .into_iter()
                    .map(|(_, p)| p)
                    .collect(),
            )
            .unwrap();
            assert!(
                acc.closest_hit(&v.ray(4.0, 4.0), 0.0, f64::INFINITY)
                    .is_some(),
                "{name}"
            );
        }
        assert!(auto_camera(&builtin::occluded(), DVec3::ZERO).is_err());
    }

    #[test]
    fn rejects_bad_input() {
        assert!(View::look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 1.0, 8, 8).is_err());
        assert!(View::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 4.0, 8, 8).is_err());
        assert!(View::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 1.0, 0, 8).is_err());
    }
}
