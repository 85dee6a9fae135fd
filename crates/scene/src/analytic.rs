//! Analytic surface patches (VirtualMesh §3.1, Appendix A.1): spheres, spheroids,
//! cylinders, cones and ring tori, each a patch of `wavelux-param`'s equal-area
//! parametrization of the unit square, optionally trimmed by loops of segments and
//! arcs in that unit square (VirtualMesh §4, trimmed patches).
//!
//! Because the map is equal-area (constant Jacobian), the area of a trimmed patch is
//! exactly `area(untrimmed) × area(trim region)`.
//!
//! Orientation: the front side is the parametrization's normal, which points away
//! from the axis (cylinder, cone), from the centre (sphere, spheroid) or from the tube
//! axis (torus). A surface seen from inside (a dome over a room) is made two-sided
//! with a black front material, which is radiometrically a one-sided inward surface.

use std::sync::Arc;

use glam::DVec3;
use wavelux_param::{Frame, Parametrization};

use crate::error::SceneError;
use crate::shape::Loop;

/// The placement of an analytic surface: local `z` along `axis`, local `x` along the
/// part of `reference` orthogonal to `axis` (azimuth 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Placement {
    /// Centre (sphere, spheroid, torus), base centre (cylinder) or apex (cone).
    pub origin: DVec3,
    /// Symmetry axis (need not be unit).
    pub axis: DVec3,
    /// Azimuth-zero direction (need not be unit or orthogonal to `axis`).
    pub reference: DVec3,
}

/// An analytic surface patch; angles in radians.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum AnalyticSurface {
    /// Sphere patch of `radius`, azimuth range and latitude range (`[−π/2, π/2]`).
    Sphere {
        /// Placement (origin = centre).
        placement: Placement,
        /// Radius (`> 0`).
        radius: f64,
        /// Azimuth range (length `<= 2π`).
        azimuth: (f64, f64),
        /// Latitude range within `[−π/2, π/2]`.
        latitude: (f64, f64),
    },
    /// Spheroid patch with equatorial and polar semi-axes.
    Spheroid {
        /// Placement (origin = centre, axis = polar axis).
        placement: Placement,
        /// Equatorial semi-axis (`> 0`).
        equatorial: f64,
        /// Polar semi-axis (`> 0`).
        polar: f64,
        /// Azimuth range.
        azimuth: (f64, f64),
        /// Latitude range.
        latitude: (f64, f64),
    },
    /// Open cylinder patch.
    Cylinder {
        /// Placement (origin = axis point at height 0).
        placement: Placement,
        /// Radius (`> 0`).
        radius: f64,
        /// Azimuth range.
        azimuth: (f64, f64),
        /// Height range along the axis.
        height: (f64, f64),
    },
    /// Open cone patch with apex at the origin: local `(a φ cos θ, a φ sin θ, b φ)`.
    Cone {
        /// Placement (origin = apex).
        placement: Placement,
        /// Radius `a` of the cross-section at `φ = 1`.
        radius: f64,
        /// Height `b` of the cross-section at `φ = 1`.
        height: f64,
        /// Azimuth range.
        azimuth: (f64, f64),
        /// Generator range `0 <= φ0 < φ1`.
        generator: (f64, f64),
    },
    /// Ring-torus patch (`minor < major`).
    Torus {
        /// Placement (origin = centre).
        placement: Placement,
        /// Major radius `R`.
        major: f64,
        /// Minor (tube) radius `r < R`.
        minor: f64,
        /// Azimuth range about the axis.
        azimuth: (f64, f64),
        /// Tube-angle range.
        tube: (f64, f64),
    },
}

/// An analytic patch with an optional trim region in the equal-area unit square.
#[derive(Debug, Clone, PartialEq)]
pub struct AnalyticPatch {
    /// The surface.
    pub surface: AnalyticSurface,
    /// Trim region in the equal-area unit square `[0,1]²`; `None` keeps the whole
    /// patch.
    pub trim: Option<Region>,
}

/// A planar region: one outer loop and disjoint holes inside it (either orientation).
#[derive(Debug, Clone, PartialEq)]
pub struct Region {
    /// Outer boundary.
    pub outer: Loop,
    /// Holes.
    pub holes: Vec<Loop>,
}

impl Region {
    /// Area `|outer| − Σ|holes|`.
    pub fn area(&self) -> f64 {
        self.outer.signed_area().abs()
            - self
                .holes
                .iter()
                .map(|h| h.signed_area().abs())
                .sum::<f64>()
    }
}

impl AnalyticSurface {
    /// The placement.
    pub fn placement(&self) -> &Placement {
        match self {
            Self::Sphere { placement, .. }
            | Self::Spheroid { placement, .. }
            | Self::Cylinder { placement, .. }
            | Self::Cone { placement, .. }
            | Self::Torus { placement, .. } => placement,
        }
    }

    /// The same surface under the similarity `x ↦ s·R·x + t` given as a matrix whose
    /// linear part is a rotation times a positive uniform scale; `None` otherwise.
    pub fn transformed(&self, m: &glam::DMat4) -> Option<Self> {
        let lin = glam::DMat3::from_mat4(*m);
        let s = lin.determinant().cbrt();
        if !(s > 0.0) {
            return None;
        }
        let r = lin * (1.0 / s);
        let ortho = (r.transpose() * r - glam::DMat3::IDENTITY)
            .to_cols_array()
            .iter()
            .all(|x| x.abs() < 1e-12);
        if !ortho {
            return None;
        }
        let mut out = *self;
        let p = match &mut out {
            Self::Sphere {
                placement, radius, ..
            } => {
                *radius *= s;
                placement
            }
            Self::Spheroid {
                placement,
                equatorial,
                polar,
                ..
            } => {
                *equatorial *= s;
                *polar *= s;
                placement
            }
            Self::Cylinder {
                placement,
                radius,
                height,
                ..
            } => {
                *radius *= s;
                *height = (height.0 * s, height.1 * s);
                placement
            }
            Self::Cone {
                placement,
                radius,
                height,
                ..
            } => {
                *radius *= s;
                *height *= s;
                placement
            }
            Self::Torus {
                placement,
                major,
                minor,
                ..
            } => {
                *major *= s;
                *minor *= s;
                placement
            }
        };
        p.origin = m.transform_point3(p.origin);
        p.axis = r * p.axis;
        p.reference = r * p.reference;
        Some(out)
    }

    /// Builds the `wavelux-param` equal-area parametrization.
    pub fn parametrization(
        &self,
        file: &str,
        element: &str,
    ) -> Result<Arc<dyn Parametrization>, SceneError> {
        let perr = |e: wavelux_param::ParamError| SceneError::Malformed {
            file: file.into(),
            element: element.into(),
            what: e.to_string(),
        };
        let p = self.placement();
        let frame = Frame::new(p.origin, p.axis, p.reference).map_err(perr)?;
        Ok(match *self {
            Self::Sphere {
                radius,
                azimuth,
                latitude,
                ..
            } => Arc::new(
                wavelux_param::Sphere::new(frame, radius, azimuth, latitude)
                    .map_err(perr)?
                    .equal_area(),
            ),
            Self::Spheroid {
                equatorial,
                polar,
                azimuth,
                latitude,
                ..
            } => Arc::new(
                wavelux_param::Spheroid::new(frame, equatorial, polar, azimuth, latitude)
                    .map_err(perr)?
                    .equal_area(),
            ),
            Self::Cylinder {
                radius,
                azimuth,
                height,
                ..
            } => Arc::new(
                wavelux_param::Cylinder::new(frame, radius, azimuth, height)
                    .map_err(perr)?
                    .equal_area(),
            ),
            Self::Cone {
                radius,
                height,
                azimuth,
                generator,
                ..
            } => Arc::new(
                wavelux_param::Cone::new(frame, radius, height, azimuth, generator)
                    .map_err(perr)?
                    .equal_area(),
            ),
            Self::Torus {
                major,
                minor,
                azimuth,
                tube,
                ..
            } => Arc::new(
                wavelux_param::Torus::new(frame, major, minor, azimuth, tube)
                    .map_err(perr)?
                    .equal_area(),
            ),
        })
    }
}

impl AnalyticPatch {
    /// Area of the kept region of the trim (outer loops minus holes), in the unit
    /// square; 1 without a trim.
    pub fn trim_fraction(&self) -> f64 {
        match &self.trim {
            None => 1.0,
            Some(r) => r.area(),
        }
    }
}
