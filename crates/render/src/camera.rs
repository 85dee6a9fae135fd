//! Views: a camera (glTF 2.0 §3.10 perspective or orthographic, or an explicit
//! look-at) bound to an image size, and the primary rays through its pixels.
//!
//! Pixel `(x, y)` covers `[x, x+1] × [y, y+1]` in raster space, `y` growing downwards;
//! a sample at offset `(jx, jy) ∈ [0,1)²` inside it goes through the image-plane point
//! `((x+jx)/w·2−1)·tan(yfov/2)·aspect` right and `(1−(y+jy)/h·2)·tan(yfov/2)` up.

use glam::DVec3;
use wavelux_geometry::Ray;
use wavelux_scene::{Camera, Projection};

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
    fn rejects_bad_input() {
        assert!(View::look_at(DVec3::ZERO, DVec3::ZERO, DVec3::Y, 1.0, 8, 8).is_err());
        assert!(View::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 4.0, 8, 8).is_err());
        assert!(View::look_at(DVec3::ZERO, DVec3::Z, DVec3::Y, 1.0, 0, 8).is_err());
    }
}
