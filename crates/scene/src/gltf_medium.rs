//! The glTF node extension `WAVELUX_medium`: a participating medium (GlobalCube §2.1)
//! on the node's unit cube. It belongs in `extensionsUsed` only (a viewer that does not
//! know it still shows the meshes).
//!
//! ```json
//! "nodes": [{
//!   "name": "haze",
//!   "translation": [0, 0, 0], "scale": [4, 4, 4],
//!   "extensions": { "WAVELUX_medium": {
//!     "resolution": [16, 16, 16],
//!     "opacity": { "accessor": 3 },
//!     "source": [0, 0, 0],
//!     "albedo": 0.8
//!   } }
//! }]
//! ```
//!
//! The box is the unit cube `[0, 1]³` of the node's frame under its world transform,
//! which must be a positive scale and a translation (media are axis-aligned). Each grid
//! is a number (grey constant), `[r, g, b]` (constant colour; not for opacity) or
//! `{ "accessor": i }`: a `FLOAT` accessor of `nx·ny·nz` `SCALAR` (grey) or `VEC3`
//! (RGB) elements, x fastest. Units as in the native format (source W/m³ in scene
//! units).

use glam::{DMat4, DVec3};
use serde::Deserialize;

use crate::error::SceneError;
use crate::material::Rgb;
use crate::medium::Medium;

/// The extension's name.
pub const EXTENSION: &str = "WAVELUX_medium";

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Spec {
    resolution: [usize; 3],
    opacity: GridSpec,
    source: GridSpec,
    albedo: GridSpec,
}

#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum GridSpec {
    Grey(f64),
    Rgb([f64; 3]),
    Accessor { accessor: usize },
}

/// Reads the accessor `index` as `f32` values: `(values, components per element)`.
pub(crate) type ReadFloats<'r> = dyn Fn(usize, &str) -> Result<(Vec<f64>, usize), SceneError> + 'r;

/// Builds the medium of a node carrying the extension.
pub(crate) fn medium(
    file: &str,
    node: usize,
    name: Option<&str>,
    value: &gltf::json::Value,
    world: &DMat4,
    read: &ReadFloats<'_>,
) -> Result<Medium, SceneError> {
    let element = format!("node {node} {EXTENSION}");
    let malformed = |what: String| SceneError::Malformed {
        file: file.into(),
        element: element.clone(),
        what,
    };
    let spec: Spec =
        gltf::json::deserialize::from_value(value.clone()).map_err(|e| malformed(e.to_string()))?;
    let [nx, ny, nz] = spec.resolution;
    let n = nx
        .checked_mul(ny)
        .and_then(|v| v.checked_mul(nz))
        .filter(|&v| v > 0 && v <= crate::native::MAX_VOXELS)
        .ok_or_else(|| {
            malformed(format!(
                "resolution {:?} must be positive with at most {} voxels",
                spec.resolution,
                crate::native::MAX_VOXELS
            ))
        })?;
    // Axis-aligned: no rotation or shear, positive scale.
    let m = world.to_cols_array_2d();
    for (c, col) in m.iter().take(3).enumerate() {
        for (r, &v) in col.iter().take(3).enumerate() {
            if (r == c && v <= 0.0) || (r != c && v != 0.0) {
                return Err(SceneError::Unsupported {
                    file: file.into(),
                    element,
                    what: "a medium's node transform must be a positive scale and a translation (media are axis-aligned boxes)".into(),
                });
            }
        }
    }
    let min = world.transform_point3(DVec3::ZERO);
    let max = world.transform_point3(DVec3::ONE);
    let grid = |g: &GridSpec, what: &str, grey_only: bool| -> Result<Vec<Rgb>, SceneError> {
        match g {
            GridSpec::Grey(v) => Ok(vec![Rgb::grey(*v); n]),
            GridSpec::Rgb(c) if !grey_only => Ok(vec![Rgb(*c); n]),
            GridSpec::Rgb(_) => Err(malformed(format!(
                "{what} is grey: one number or a SCALAR accessor"
            ))),
            GridSpec::Accessor { accessor } => {
                let (vals, comps) = read(*accessor, &format!("{element} {what}"))?;
                let allowed = comps == 1 || (comps == 3 && !grey_only);
                if !allowed {
                    return Err(malformed(format!(
                        "{what} accessor {accessor} has {comps} components; expected SCALAR{}",
                        if grey_only { "" } else { " or VEC3" }
                    )));
                }
                if vals.len() != n * comps {
                    return Err(malformed(format!(
                        "{what} accessor {accessor} has {} elements, expected {n}",
                        vals.len() / comps
                    )));
                }
                Ok(if comps == 1 {
                    vals.into_iter().map(Rgb::grey).collect()
                } else {
                    vals.chunks_exact(3)
                        .map(|c| Rgb::new(c[0], c[1], c[2]))
                        .collect()
                })
            }
        }
    };
    let medium = Medium {
        name: name.map_or_else(|| format!("medium{node}"), str::to_string),
        min,
        max,
        resolution: spec.resolution,
        source: grid(&spec.source, "source", false)?,
        opacity: grid(&spec.opacity, "opacity", true)?
            .into_iter()
            .map(|c| c.0[0])
            .collect(),
        albedo: grid(&spec.albedo, "albedo", false)?,
    };
    medium.validate(file)?;
    Ok(medium)
}
