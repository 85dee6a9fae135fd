//! Analytic surfaces with unit-square parametrizations: sphere, spheroid, cylinder,
//! cone, torus (the quadrics and the torus of the issue; Ziegler §2.1: every surface is
//! a map from `[0,1]²`).
//!
//! Each surface lives in a local orthonormal [`Frame`]; `u` is always the azimuth
//! `φ = 2πu` about the frame's `z` axis; `v` is surface specific (see [`Surface`]).
//! Normals point outwards (away from the axis / centre).

use glam::{DVec2, DVec3};
use std::f64::consts::{PI, TAU};

use crate::GeometryError;
use crate::primitive::Aabb;

/// A right-handed orthonormal frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    /// Origin.
    pub origin: DVec3,
    /// Unit x axis.
    pub x: DVec3,
    /// Unit y axis.
    pub y: DVec3,
    /// Unit z axis (`x × y`), the axis of rotational surfaces.
    pub z: DVec3,
}

impl Frame {
    /// Frame with the given origin and `z` axis (normalised); `x` is chosen deterministically.
    ///
    /// # Errors
    /// Non-finite input or zero axis.
    pub fn from_axis(origin: DVec3, axis: DVec3) -> Result<Frame, GeometryError> {
        if !origin.is_finite() || !axis.is_finite() {
            return Err(GeometryError::NonFinite("frame"));
        }
        let z = axis
            .try_normalize()
            .ok_or(GeometryError::Degenerate("zero frame axis"))?;
        let x = z.any_orthonormal_vector();
        Ok(Frame {
            origin,
            x,
            y: z.cross(x),
            z,
        })
    }

    /// The world frame translated to `origin`.
    pub fn at(origin: DVec3) -> Frame {
        Frame {
            origin,
            x: DVec3::X,
            y: DVec3::Y,
            z: DVec3::Z,
        }
    }

    /// Local coordinates of a world point.
    pub fn to_local(&self, p: DVec3) -> DVec3 {
        let d = p - self.origin;
        DVec3::new(d.dot(self.x), d.dot(self.y), d.dot(self.z))
    }

    /// Local components of a world vector.
    pub fn vec_to_local(&self, d: DVec3) -> DVec3 {
        DVec3::new(d.dot(self.x), d.dot(self.y), d.dot(self.z))
    }

    /// World point of local coordinates.
    pub fn to_world(&self, q: DVec3) -> DVec3 {
        self.origin + q.x * self.x + q.y * self.y + q.z * self.z
    }

    /// World vector of local components.
    pub fn vec_to_world(&self, q: DVec3) -> DVec3 {
        q.x * self.x + q.y * self.y + q.z * self.z
    }
}

/// An analytic surface over `[0,1]²` (`φ = 2πu` about the local `z` axis).
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Surface {
    /// Sphere of radius `radius`; `z = r(2v − 1)` (Archimedes' equal-area map).
    Sphere {
        /// Local frame (centre at the origin).
        frame: Frame,
        /// Radius.
        radius: f64,
    },
    /// Spheroid `(x² + y²)/a² + z²/c² = 1`; `z = c(2v − 1)`, `ρ = a √(1 − (2v−1)²)`.
    Spheroid {
        /// Local frame (centre at the origin, symmetry axis `z`).
        frame: Frame,
        /// Equatorial semi-axis.
        a: f64,
        /// Polar semi-axis.
        c: f64,
    },
    /// Open cylinder `x² + y² = r²`, `z = v · height`.
    Cylinder {
        /// Local frame (base centre at the origin).
        frame: Frame,
        /// Radius.
        radius: f64,
        /// Height.
        height: f64,
    },
    /// Open cone with base radius `radius` at `z = 0` and apex at `z = height`:
    /// `ρ = radius (1 − v)`, `z = v · height`.
    Cone {
        /// Local frame (base centre at the origin).
        frame: Frame,
        /// Base radius.
        radius: f64,
        /// Height.
        height: f64,
    },
    /// Torus `(√(x²+y²) − R)² + z² = r²`; tube angle `θ = 2πv`:
    /// `((R + r cos θ) cos φ, (R + r cos θ) sin φ, r sin θ)`.
    Torus {
        /// Local frame (centre at the origin, axis `z`).
        frame: Frame,
        /// Major radius `R`.
        major: f64,
        /// Minor (tube) radius `r < R`.
        minor: f64,
    },
}

fn pos(x: f64, what: &'static str) -> Result<(), GeometryError> {
    if !x.is_finite() {
        Err(GeometryError::NonFinite(what))
    } else if x <= 0.0 {
        Err(GeometryError::Degenerate(what))
    } else {
        Ok(())
    }
}

impl Surface {
    /// Sphere.
    ///
    /// # Errors
    /// Non-positive or non-finite radius.
    pub fn sphere(frame: Frame, radius: f64) -> Result<Surface, GeometryError> {
        pos(radius, "sphere radius")?;
        Ok(Surface::Sphere { frame, radius })
    }

    /// Spheroid.
    ///
    /// # Errors
    /// Non-positive or non-finite semi-axes.
    pub fn spheroid(frame: Frame, a: f64, c: f64) -> Result<Surface, GeometryError> {
        pos(a, "spheroid semi-axis")?;
        pos(c, "spheroid semi-axis")?;
        Ok(Surface::Spheroid { frame, a, c })
    }

    /// Cylinder.
    ///
    /// # Errors
    /// Non-positive or non-finite dimensions.
    pub fn cylinder(frame: Frame, radius: f64, height: f64) -> Result<Surface, GeometryError> {
        pos(radius, "cylinder radius")?;
        pos(height, "cylinder height")?;
        Ok(Surface::Cylinder {
            frame,
            radius,
            height,
        })
    }

    /// Cone.
    ///
    /// # Errors
    /// Non-positive or non-finite dimensions.
    pub fn cone(frame: Frame, radius: f64, height: f64) -> Result<Surface, GeometryError> {
        pos(radius, "cone radius")?;
        pos(height, "cone height")?;
        Ok(Surface::Cone {
            frame,
            radius,
            height,
        })
    }

    /// Ring torus (`0 < minor < major`).
    ///
    /// # Errors
    /// Non-positive, non-finite radii, or `minor >= major`.
    pub fn torus(frame: Frame, major: f64, minor: f64) -> Result<Surface, GeometryError> {
        pos(major, "torus major radius")?;
        pos(minor, "torus minor radius")?;
        if minor >= major {
            return Err(GeometryError::Degenerate("torus needs minor < major"));
        }
        Ok(Surface::Torus {
            frame,
            major,
            minor,
        })
    }

    /// The surface's frame.
    pub fn frame(&self) -> &Frame {
        match self {
            Surface::Sphere { frame, .. }
            | Surface::Spheroid { frame, .. }
            | Surface::Cylinder { frame, .. }
            | Surface::Cone { frame, .. }
            | Surface::Torus { frame, .. } => frame,
        }
    }

    /// Point in local coordinates.
    pub fn eval_local(&self, uv: DVec2) -> DVec3 {
        let (s, c) = (TAU * uv.x).sin_cos();
        match *self {
            Surface::Sphere { radius, .. } => {
                let z = 2.0 * uv.y - 1.0;
                let rho = (1.0 - z * z).max(0.0).sqrt();
                radius * DVec3::new(rho * c, rho * s, z)
            }
            Surface::Spheroid { a, c: cc, .. } => {
                let z = 2.0 * uv.y - 1.0;
                let rho = (1.0 - z * z).max(0.0).sqrt();
                DVec3::new(a * rho * c, a * rho * s, cc * z)
            }
            Surface::Cylinder { radius, height, .. } => {
                DVec3::new(radius * c, radius * s, height * uv.y)
            }
            Surface::Cone { radius, height, .. } => {
                let rho = radius * (1.0 - uv.y);
                DVec3::new(rho * c, rho * s, height * uv.y)
            }
            Surface::Torus { major, minor, .. } => {
                let (st, ct) = (TAU * uv.y).sin_cos();
                let rho = major + minor * ct;
                DVec3::new(rho * c, rho * s, minor * st)
            }
        }
    }

    /// Point in world coordinates.
    pub fn eval(&self, uv: DVec2) -> DVec3 {
        self.frame().to_world(self.eval_local(uv))
    }

    /// Unit outward normal at a local point on the surface (gradient of the implicit form).
    pub fn normal_local(&self, q: DVec3) -> DVec3 {
        let g = match *self {
            Surface::Sphere { .. } => q,
            Surface::Spheroid { a, c, .. } => {
                DVec3::new(q.x / (a * a), q.y / (a * a), q.z / (c * c))
            }
            Surface::Cylinder { .. } => DVec3::new(q.x, q.y, 0.0),
            Surface::Cone { radius, height, .. } => {
                // ρ = radius (1 − z/h): gradient of ρ − radius(1 − z/h).
                let rho = (q.x * q.x + q.y * q.y).sqrt().max(f64::MIN_POSITIVE);
                DVec3::new(q.x / rho, q.y / rho, radius / height)
            }
            Surface::Torus { major, .. } => {
                let rho = (q.x * q.x + q.y * q.y).sqrt().max(f64::MIN_POSITIVE);
                let k = 1.0 - major / rho;
                DVec3::new(q.x * k, q.y * k, q.z)
            }
        };
        g.try_normalize().unwrap_or(DVec3::Z)
    }

    /// Unit outward normal in world coordinates at parameters `uv`.
    pub fn normal(&self, uv: DVec2) -> DVec3 {
        self.frame()
            .vec_to_world(self.normal_local(self.eval_local(uv)))
    }

    /// Parameters of a local point on (or near) the surface; inverse of [`Surface::eval_local`].
    pub fn uv_of_local(&self, q: DVec3) -> DVec2 {
        let u = (q.y.atan2(q.x) / TAU).rem_euclid(1.0);
        let v = match *self {
            Surface::Sphere { radius, .. } => 0.5 * (q.z / radius + 1.0),
            Surface::Spheroid { c, .. } => 0.5 * (q.z / c + 1.0),
            Surface::Cylinder { height, .. } | Surface::Cone { height, .. } => q.z / height,
            Surface::Torus { major, .. } => {
                let rho = (q.x * q.x + q.y * q.y).sqrt();
                (q.z.atan2(rho - major) / TAU).rem_euclid(1.0)
            }
        };
        DVec2::new(u, v.clamp(0.0, 1.0))
    }

    /// Bounding box of the whole surface.
    pub fn aabb(&self) -> Aabb {
        let (lo, hi) = match *self {
            Surface::Sphere { radius, .. } => (DVec3::splat(-radius), DVec3::splat(radius)),
            Surface::Spheroid { a, c, .. } => (DVec3::new(-a, -a, -c), DVec3::new(a, a, c)),
            Surface::Cylinder { radius, height, .. } | Surface::Cone { radius, height, .. } => (
                DVec3::new(-radius, -radius, 0.0),
                DVec3::new(radius, radius, height),
            ),
            Surface::Torus { major, minor, .. } => {
                let r = major + minor;
                (DVec3::new(-r, -r, -minor), DVec3::new(r, r, minor))
            }
        };
        let f = self.frame();
        let mut b = Aabb::EMPTY;
        for k in 0..8 {
            let q = DVec3::new(
                if k & 1 == 0 { lo.x } else { hi.x },
                if k & 2 == 0 { lo.y } else { hi.y },
                if k & 4 == 0 { lo.z } else { hi.z },
            );
            b.grow(f.to_world(q));
        }
        b
    }

    /// Area of the whole (untrimmed) surface, closed form.
    pub fn area(&self) -> f64 {
        match *self {
            Surface::Sphere { radius, .. } => 4.0 * PI * radius * radius,
            Surface::Spheroid { a, c, .. } => {
                if (a - c).abs() <= 1e-12 * a {
                    4.0 * PI * a * a
                } else if c < a {
                    let e = (1.0 - c * c / (a * a)).sqrt();
                    2.0 * PI * a * a * (1.0 + (1.0 - e * e) / e * e.atanh())
                } else {
                    let e = (1.0 - a * a / (c * c)).sqrt();
                    2.0 * PI * a * a * (1.0 + c / (a * e) * e.asin())
                }
            }
            Surface::Cylinder { radius, height, .. } => TAU * radius * height,
            Surface::Cone { radius, height, .. } => {
                PI * radius * (radius * radius + height * height).sqrt()
            }
            Surface::Torus { major, minor, .. } => 4.0 * PI * PI * major * minor,
        }
    }
}
