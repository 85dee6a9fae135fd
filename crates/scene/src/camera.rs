//! Cameras: a pinhole (perspective) or orthographic view, as glTF 2.0 §3.10 defines
//! them (looking down the camera's local `−z`, `+y` up).

use glam::DVec3;

/// Projection of a camera.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Projection {
    /// Perspective projection.
    Perspective {
        /// Vertical field of view in radians, in `(0, π)`.
        yfov: f64,
        /// Width / height; `None` lets the renderer use the image's.
        aspect: Option<f64>,
    },
    /// Orthographic projection.
    Orthographic {
        /// Half-width of the view volume (scene units).
        xmag: f64,
        /// Half-height of the view volume (scene units).
        ymag: f64,
    },
}

/// A camera.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    /// Name (glTF node/camera name or native `name`).
    pub name: String,
    /// Eye position.
    pub position: DVec3,
    /// Unit viewing direction.
    pub forward: DVec3,
    /// Unit up direction, orthogonal to `forward`.
    pub up: DVec3,
    /// Projection.
    pub projection: Projection,
}

impl Camera {
    /// A perspective camera at `position` looking at `target`, with `up` hint
    /// (re-orthogonalised) and vertical field of view `yfov` (radians). Returns `None`
    /// if the directions are degenerate or not finite.
    pub fn look_at(
        name: impl Into<String>,
        position: DVec3,
        target: DVec3,
        up: DVec3,
        yfov: f64,
        aspect: Option<f64>,
    ) -> Option<Self> {
        let forward = (target - position).try_normalize()?;
        let up = (up - forward * forward.dot(up)).try_normalize()?;
        (position.is_finite() && yfov.is_finite() && yfov > 0.0 && yfov < std::f64::consts::PI)
            .then(|| Self {
                name: name.into(),
                position,
                forward,
                up,
                projection: Projection::Perspective { yfov, aspect },
            })
    }

    /// The unit right direction `forward × up`.
    pub fn right(&self) -> DVec3 {
        self.forward.cross(self.up)
    }
}
