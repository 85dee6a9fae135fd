//! The native scene format: TOML, for what glTF cannot say — analytic and trimmed
//! surfaces, complex polygons with arcs and holes, Bézier patches, participating
//! media and method defaults — and able to include glTF and other native files.
//! The format is documented with examples in `docs/scene-format.md`; this module is
//! its schema (serde) and its translation into a [`Scene`].
//!
//! Units: lengths in scene units, angles in **degrees** (`*_deg` keys), emission as
//! radiant exitance `E` (W/m² per RGB channel; see [`crate::material`]).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{DMat4, DVec2, DVec3};
use serde::Deserialize;

use crate::LoadOptions;
use crate::analytic::{AnalyticPatch, AnalyticSurface, Placement, Region};
use crate::camera::Camera;
use crate::error::{MEMORY_FILE, SceneError, Warning, WarningKind};
use crate::gltf_load::{GltfOptions, load_gltf};
use crate::group::{MeshGrouping, MeshPart, group_mesh, reversed_sides};
use crate::material::{EmissionProfile, Material, ReflectancePolicy, Rgb, WardParams};
use crate::medium::Medium;
use crate::scene::{DefaultValue, Scene, Sidedness, Surface};
use crate::shape::{BezierPatch, Loop, LoopEdge, PlaneFrame, PolygonShape, Shape, TriangleMesh};

/// Largest voxel count of a medium accepted by the native loader (`256³`).
pub const MAX_VOXELS: usize = 1 << 24;

/// Deepest include nesting accepted.
pub const MAX_INCLUDE_DEPTH: usize = 16;

// ------------------------------------------------------------------------------------
// Schema
// ------------------------------------------------------------------------------------

/// A whole native file.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileSpec {
    /// Scene name (default: the file stem).
    name: Option<String>,
    #[serde(default)]
    defaults: BTreeMap<String, toml::Value>,
    #[serde(default)]
    include: Vec<IncludeSpec>,
    #[serde(default)]
    material: Vec<MaterialSpec>,
    #[serde(default)]
    surface: Vec<SurfaceSpec>,
    #[serde(default)]
    medium: Vec<MediumSpec>,
    #[serde(default)]
    camera: Vec<CameraSpec>,
    #[serde(default)]
    light: Vec<LightSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct IncludeSpec {
    path: String,
    #[serde(default)]
    prefix: String,
    /// Uniform scale applied before `translate`.
    scale: Option<f64>,
    translate: Option<[f64; 3]>,
    /// glTF only: clamp reflectances into `[0, clamp_reflectance]` instead of failing.
    clamp_reflectance: Option<f64>,
}

/// A colour: one number (grey) or `[r, g, b]`.
#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(untagged)]
enum ColorSpec {
    Grey(f64),
    Rgb([f64; 3]),
}

impl ColorSpec {
    fn rgb(self) -> Rgb {
        match self {
            Self::Grey(v) => Rgb::grey(v),
            Self::Rgb(c) => Rgb(c),
        }
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct WardSpec {
    specular: ColorSpec,
    alpha_x: f64,
    alpha_y: Option<f64>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSpec {
    name: String,
    reflectance: ColorSpec,
    emission: Option<ColorSpec>,
    /// Directional emitter: radiance ∝ cos^n θ.
    emission_exponent: Option<f64>,
    ward: Option<WardSpec>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct SurfaceSpec {
    name: String,
    material: String,
    /// Makes the surface two-sided with this back material.
    back_material: Option<String>,
    /// Direction of Ward's `α_x` (projected onto the tangent plane where used).
    tangent: Option<[f64; 3]>,
    shape: ShapeSpec,
}

#[derive(Debug, Deserialize, Clone, Copy)]
#[serde(deny_unknown_fields)]
struct EdgeSpec {
    start: [f64; 2],
    /// Present for an arc.
    center: Option<[f64; 2]>,
    /// Arc direction (default counter-clockwise).
    ccw: Option<bool>,
}

fn to_loop(edges: &[EdgeSpec]) -> Loop {
    Loop {
        edges: edges
            .iter()
            .map(|e| match e.center {
                None => LoopEdge::Segment {
                    start: DVec2::from_array(e.start),
                },
                Some(c) => LoopEdge::Arc {
                    start: DVec2::from_array(e.start),
                    center: DVec2::from_array(c),
                    ccw: e.ccw.unwrap_or(true),
                },
            })
            .collect(),
    }
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct TrimSpec {
    outer: Vec<EdgeSpec>,
    #[serde(default)]
    holes: Vec<Vec<EdgeSpec>>,
}

impl TrimSpec {
    fn region(&self) -> Region {
        Region {
            outer: to_loop(&self.outer),
            holes: self.holes.iter().map(|h| to_loop(h)).collect(),
        }
    }
}

const DEFAULT_AXIS: [f64; 3] = [0.0, 0.0, 1.0];

#[derive(Debug, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
enum ShapeSpec {
    Triangle {
        vertices: [[f64; 3]; 3],
    },
    Parallelogram {
        origin: [f64; 3],
        edge_u: [f64; 3],
        edge_v: [f64; 3],
    },
    /// Planar quad through 4 corners (two triangles, merged when a parallelogram).
    Quad {
        corners: [[f64; 3]; 4],
    },
    Mesh {
        positions: Vec<[f64; 3]>,
        triangles: Vec<[u32; 3]>,
    },
    Polygon {
        origin: [f64; 3],
        u: [f64; 3],
        v: [f64; 3],
        outer: Vec<EdgeSpec>,
        #[serde(default)]
        holes: Vec<Vec<EdgeSpec>>,
    },
    Bezier {
        degree: [usize; 2],
        control: Vec<[f64; 3]>,
    },
    Sphere {
        center: [f64; 3],
        radius: f64,
        axis: Option<[f64; 3]>,
        reference: Option<[f64; 3]>,
        azimuth_deg: Option<[f64; 2]>,
        latitude_deg: Option<[f64; 2]>,
        trim: Option<TrimSpec>,
    },
    Spheroid {
        center: [f64; 3],
        equatorial: f64,
        polar: f64,
        axis: Option<[f64; 3]>,
        reference: Option<[f64; 3]>,
        azimuth_deg: Option<[f64; 2]>,
        latitude_deg: Option<[f64; 2]>,
        trim: Option<TrimSpec>,
    },
    Cylinder {
        base: [f64; 3],
        radius: f64,
        height: f64,
        axis: Option<[f64; 3]>,
        reference: Option<[f64; 3]>,
        azimuth_deg: Option<[f64; 2]>,
        trim: Option<TrimSpec>,
    },
    Cone {
        apex: [f64; 3],
        /// Radius of the cross-section at `height` from the apex.
        radius: f64,
        height: f64,
        axis: Option<[f64; 3]>,
        reference: Option<[f64; 3]>,
        azimuth_deg: Option<[f64; 2]>,
        /// Kept part of the generator, as fractions of `height` (default `[0, 1]`).
        generator: Option<[f64; 2]>,
        trim: Option<TrimSpec>,
    },
    Torus {
        center: [f64; 3],
        major: f64,
        minor: f64,
        axis: Option<[f64; 3]>,
        reference: Option<[f64; 3]>,
        azimuth_deg: Option<[f64; 2]>,
        tube_deg: Option<[f64; 2]>,
        trim: Option<TrimSpec>,
    },
}

/// A grid: one number for every voxel, all voxel values (x fastest), or a table
/// `{ rgb = [r, g, b] }` (constant colour), `{ values = [...], channels = 3 }`
/// (interleaved RGB) or `{ file = "s.raw", channels = 1 | 3 }` (raw little-endian f32,
/// relative to the scene file).
#[derive(Debug, Deserialize)]
#[serde(untagged)]
enum GridSpec {
    Constant(f64),
    Values(Vec<f64>),
    Table(GridTable),
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct GridTable {
    rgb: Option<[f64; 3]>,
    values: Option<Vec<f64>>,
    file: Option<String>,
    channels: Option<usize>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MediumSpec {
    name: String,
    min: [f64; 3],
    max: [f64; 3],
    resolution: [usize; 3],
    source: GridSpec,
    opacity: GridSpec,
    albedo: GridSpec,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSpec {
    name: String,
    position: [f64; 3],
    target: [f64; 3],
    up: Option<[f64; 3]>,
    yfov_deg: f64,
    aspect: Option<f64>,
}

/// A punctual light (`[[light]]`): `type = "point"` or `"spot"`; intensity in W/sr.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LightSpec {
    name: String,
    #[serde(rename = "type")]
    kind: String,
    position: [f64; 3],
    intensity: ColorSpec,
    /// Spot axis (required for spots).
    direction: Option<[f64; 3]>,
    /// Spot outer cone half-angle in degrees, `(0, 180]` (required for spots).
    outer_deg: Option<f64>,
    /// Spot inner cone half-angle in degrees (default: `outer_deg`, a hard edge).
    inner_deg: Option<f64>,
}

fn light_from_spec(l: &LightSpec, file: &str) -> Result<crate::light::Light, SceneError> {
    use crate::light::Light;
    let element = format!("light {:?}", l.name);
    let position = DVec3::from_array(l.position);
    let light = match l.kind.as_str() {
        "point" => {
            if l.direction.is_some() || l.outer_deg.is_some() || l.inner_deg.is_some() {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element,
                    what: "a point light takes no direction or cone angles".into(),
                });
            }
            Light::point(l.name.clone(), position, l.intensity.rgb())
        }
        "spot" => {
            let (Some(dir), Some(outer)) = (l.direction, l.outer_deg) else {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element,
                    what: "a spot light needs `direction` and `outer_deg`".into(),
                });
            };
            let dir = DVec3::from_array(dir);
            let mut light = Light::spot(
                l.name.clone(),
                position,
                dir,
                l.inner_deg.unwrap_or(outer).to_radians(),
                outer.to_radians(),
                l.intensity.rgb(),
            );
            // Keep a non-finite direction visible to `validate`.
            if let crate::light::LightKind::Spot { direction, .. } = &mut light.kind
                && !dir.is_finite()
            {
                *direction = dir;
            }
            light
        }
        other => {
            return Err(SceneError::Malformed {
                file: file.into(),
                element,
                what: format!("unknown light type {other:?} (expected \"point\" or \"spot\")"),
            });
        }
    };
    light.validate(file)?;
    Ok(light)
}

// ------------------------------------------------------------------------------------
// Translation
// ------------------------------------------------------------------------------------

/// Loads a native `.toml` scene file (and everything it includes; relative include
/// paths resolve against the including file's directory).
pub fn load_native(path: impl AsRef<Path>) -> Result<Scene, SceneError> {
    load_native_with(path, &LoadOptions::default())
}

/// [`load_native`] with loader options (mesh grouping of `mesh` surfaces and of
/// included glTF files).
pub fn load_native_with(
    path: impl AsRef<Path>,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    let mut stack = Vec::new();
    load_native_rec(path.as_ref(), &mut stack, options)
}

fn load_native_rec(
    path: &Path,
    stack: &mut Vec<PathBuf>,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    let file = path.display().to_string();
    let canon = std::fs::canonicalize(path).map_err(|e| SceneError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    if stack.contains(&canon) || stack.len() >= MAX_INCLUDE_DEPTH {
        let mut chain: Vec<String> = stack.iter().map(|p| p.display().to_string()).collect();
        chain.push(canon.display().to_string());
        return Err(SceneError::IncludeCycle {
            file,
            chain: chain.join(" -> "),
            max_depth: MAX_INCLUDE_DEPTH,
        });
    }
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::Io {
        file: file.clone(),
        message: e.to_string(),
    })?;
    stack.push(canon);
    let base = path.parent().unwrap_or(Path::new("."));
    let result = parse_inner(&text, &file, Some(base), stack, options);
    stack.pop();
    let mut scene = result?;
    if scene.name.is_empty() {
        scene.name = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or_default()
            .to_string();
    }
    Ok(scene)
}

/// Parses native-format text. `file` names the source in errors; `base` resolves
/// includes (`None`: includes are an error).
pub fn parse_native(text: &str, file: &str, base: Option<&Path>) -> Result<Scene, SceneError> {
    parse_native_with(text, file, base, &LoadOptions::default())
}

/// [`parse_native`] with loader options (mesh grouping).
pub fn parse_native_with(
    text: &str,
    file: &str,
    base: Option<&Path>,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    parse_inner(text, file, base, &mut Vec::new(), options)
}

fn degrees(r: Option<[f64; 2]>, default: (f64, f64)) -> (f64, f64) {
    r.map_or(default, |[a, b]| (a.to_radians(), b.to_radians()))
}

fn placement(origin: [f64; 3], axis: Option<[f64; 3]>, reference: Option<[f64; 3]>) -> Placement {
    let axis = DVec3::from_array(axis.unwrap_or(DEFAULT_AXIS));
    // Default reference: the world axis least aligned with `axis`.
    let reference = reference.map(DVec3::from_array).unwrap_or_else(|| {
        let a = axis.abs();
        if a.x <= a.y && a.x <= a.z {
            DVec3::X
        } else if a.y <= a.z {
            DVec3::Y
        } else {
            DVec3::Z
        }
    });
    Placement {
        origin: DVec3::from_array(origin),
        axis,
        reference,
    }
}

fn shape_of(spec: &ShapeSpec, file: &str, element: &str) -> Result<(Shape, usize), SceneError> {
    use std::f64::consts::{FRAC_PI_2, PI};
    let v = DVec3::from_array;
    let full = (-PI, PI);
    let patch = |surface: AnalyticSurface, trim: &Option<TrimSpec>| {
        Shape::Patch(AnalyticPatch {
            surface,
            trim: trim.as_ref().map(TrimSpec::region),
        })
    };
    let mesh = |positions: Vec<DVec3>, tris: &[[u32; 3]]| -> Result<(Shape, usize), SceneError> {
        let b = TriangleMesh::build(positions, Vec::new(), tris, file, element)?;
        Ok((Shape::Mesh(b.mesh), b.dropped))
    };
    Ok(match spec {
        ShapeSpec::Triangle { vertices } => (Shape::Triangle(vertices.map(v)), 0),
        ShapeSpec::Parallelogram {
            origin,
            edge_u,
            edge_v,
        } => (Shape::parallelogram(v(*origin), v(*edge_u), v(*edge_v)), 0),
        ShapeSpec::Quad { corners } => {
            let p = corners.map(v);
            let n = (p[1] - p[0]).cross(p[2] - p[0]);
            let scale = (p[2] - p[0]).length().max((p[3] - p[1]).length());
            if n.length() > 0.0 && (p[3] - p[0]).dot(n.normalize()).abs() > 1e-9 * scale {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element: element.into(),
                    what: "quad corners are not coplanar".into(),
                });
            }
            mesh(p.to_vec(), &[[0, 1, 2], [0, 2, 3]])?
        }
        ShapeSpec::Mesh {
            positions,
            triangles,
        } => mesh(positions.iter().map(|p| v(*p)).collect(), triangles)?,
        ShapeSpec::Polygon {
            origin,
            u,
            v: vv,
            outer,
            holes,
        } => {
            let frame =
                PlaneFrame::from_directions(v(*origin), v(*u), v(*vv)).ok_or_else(|| {
                    SceneError::Malformed {
                        file: file.into(),
                        element: element.into(),
                        what: "polygon axes u, v are degenerate, parallel or not finite".into(),
                    }
                })?;
            (
                Shape::Polygon(PolygonShape {
                    frame,
                    outer: to_loop(outer),
                    holes: holes.iter().map(|h| to_loop(h)).collect(),
                }),
                0,
            )
        }
        ShapeSpec::Bezier { degree, control } => (
            Shape::Bezier(BezierPatch {
                degree_u: degree[0],
                degree_v: degree[1],
                control: control.iter().map(|p| v(*p)).collect(),
            }),
            0,
        ),
        ShapeSpec::Sphere {
            center,
            radius,
            axis,
            reference,
            azimuth_deg,
            latitude_deg,
            trim,
        } => (
            patch(
                AnalyticSurface::Sphere {
                    placement: placement(*center, *axis, *reference),
                    radius: *radius,
                    azimuth: degrees(*azimuth_deg, full),
                    latitude: degrees(*latitude_deg, (-FRAC_PI_2, FRAC_PI_2)),
                },
                trim,
            ),
            0,
        ),
        ShapeSpec::Spheroid {
            center,
            equatorial,
            polar,
            axis,
            reference,
            azimuth_deg,
            latitude_deg,
            trim,
        } => (
            patch(
                AnalyticSurface::Spheroid {
                    placement: placement(*center, *axis, *reference),
                    equatorial: *equatorial,
                    polar: *polar,
                    azimuth: degrees(*azimuth_deg, full),
                    latitude: degrees(*latitude_deg, (-FRAC_PI_2, FRAC_PI_2)),
                },
                trim,
            ),
            0,
        ),
        ShapeSpec::Cylinder {
            base,
            radius,
            height,
            axis,
            reference,
            azimuth_deg,
            trim,
        } => (
            patch(
                AnalyticSurface::Cylinder {
                    placement: placement(*base, *axis, *reference),
                    radius: *radius,
                    azimuth: degrees(*azimuth_deg, full),
                    height: (0.0, *height),
                },
                trim,
            ),
            0,
        ),
        ShapeSpec::Cone {
            apex,
            radius,
            height,
            axis,
            reference,
            azimuth_deg,
            generator,
            trim,
        } => (
            patch(
                AnalyticSurface::Cone {
                    placement: placement(*apex, *axis, *reference),
                    radius: *radius,
                    height: *height,
                    azimuth: degrees(*azimuth_deg, full),
                    generator: generator.map_or((0.0, 1.0), |[a, b]| (a, b)),
                },
                trim,
            ),
            0,
        ),
        ShapeSpec::Torus {
            center,
            major,
            minor,
            axis,
            reference,
            azimuth_deg,
            tube_deg,
            trim,
        } => (
            patch(
                AnalyticSurface::Torus {
                    placement: placement(*center, *axis, *reference),
                    major: *major,
                    minor: *minor,
                    azimuth: degrees(*azimuth_deg, full),
                    tube: degrees(*tube_deg, full),
                },
                trim,
            ),
            0,
        ),
    })
}

/// Expands a grid to one colour per voxel (`n` voxels). `dir` resolves grid files;
/// `element` names the medium and grid in errors; `grey_only` rejects RGB (opacity).
fn grid(
    g: &GridSpec,
    n: usize,
    dir: &Path,
    file: &str,
    element: &str,
    grey_only: bool,
) -> Result<Vec<Rgb>, SceneError> {
    let malformed = |what: String| SceneError::Malformed {
        file: file.into(),
        element: element.into(),
        what,
    };
    let out = match g {
        GridSpec::Constant(c) => vec![Rgb::grey(*c); n],
        GridSpec::Values(v) => v.iter().map(|&x| Rgb::grey(x)).collect(),
        GridSpec::Table(t) => {
            let channels = t.channels.unwrap_or(1);
            match (&t.rgb, &t.values, &t.file) {
                (Some(c), None, None) if t.channels.is_none() => vec![Rgb(*c); n],
                (None, Some(v), None) => match channels {
                    1 => v.iter().map(|&x| Rgb::grey(x)).collect(),
                    3 if v.len() % 3 == 0 => v
                        .chunks_exact(3)
                        .map(|c| Rgb::new(c[0], c[1], c[2]))
                        .collect(),
                    _ => {
                        return Err(malformed(format!(
                            "{} values with channels = {channels} (1 or 3, and a multiple of it)",
                            v.len()
                        )));
                    }
                },
                (None, None, Some(f)) => {
                    crate::medium::read_raw_grid(&dir.join(f), n, channels, element)?
                }
                _ => {
                    return Err(malformed(
                        "a grid table needs exactly one of `rgb`, `values` or `file` (`channels` only with values or file)".into(),
                    ));
                }
            }
        }
    };
    if grey_only && out.iter().any(|c| c.0[0] != c.0[1] || c.0[0] != c.0[2]) {
        return Err(malformed("opacity is grey: one channel only".into()));
    }
    Ok(out)
}

fn default_value(v: &toml::Value) -> Option<DefaultValue> {
    Some(match v {
        toml::Value::Boolean(b) => DefaultValue::Bool(*b),
        toml::Value::Integer(i) => DefaultValue::Int(*i),
        toml::Value::Float(f) => DefaultValue::Float(*f),
        toml::Value::String(s) => DefaultValue::Str(s.clone()),
        _ => return None,
    })
}

fn parse_inner(
    text: &str,
    file: &str,
    base: Option<&Path>,
    stack: &mut Vec<PathBuf>,
    options: &LoadOptions,
) -> Result<Scene, SceneError> {
    let spec: FileSpec = toml::from_str(text).map_err(|e| SceneError::Native {
        file: file.into(),
        message: e.to_string(),
    })?;
    let mut scene = Scene::new(spec.name.clone().unwrap_or_default());
    let file = if file.is_empty() { MEMORY_FILE } else { file };
    add_defaults(&mut scene, &spec, file)?;
    // Includes first, so that surfaces can use included materials.
    add_includes(&mut scene, &spec, file, base, stack, options)?;
    add_materials(&mut scene, &spec, file)?;
    add_surfaces(&mut scene, &spec, file, options)?;
    add_media(&mut scene, &spec, file, base)?;
    add_cameras(&mut scene, &spec, file)?;
    for l in &spec.light {
        let light = light_from_spec(l, file)?;
        scene.lights.push(light);
    }
    scene.validate(file)?;
    Ok(scene)
}

/// The `[defaults]` table: method defaults carried by the scene.
fn add_defaults(scene: &mut Scene, spec: &FileSpec, file: &str) -> Result<(), SceneError> {
    for (k, v) in &spec.defaults {
        let Some(d) = default_value(v) else {
            return Err(SceneError::Malformed {
                file: file.into(),
                element: format!("defaults.{k}"),
                what: "method defaults must be booleans, integers, floats or strings".into(),
            });
        };
        scene.defaults.insert(k.clone(), d);
    }
    Ok(())
}

/// `[[include]]`: glTF or native files merged under their prefix, after an optional
/// uniform scale and translation.
fn add_includes(
    scene: &mut Scene,
    spec: &FileSpec,
    file: &str,
    base: Option<&Path>,
    stack: &mut Vec<PathBuf>,
    options: &LoadOptions,
) -> Result<(), SceneError> {
    for (i, inc) in spec.include.iter().enumerate() {
        let element = format!("include {i} ({:?})", inc.path);
        let Some(base) = base else {
            return Err(SceneError::Unsupported {
                file: file.into(),
                element,
                what: "includes need a file path (parse_native was given no base)".into(),
            });
        };
        let path = base.join(&inc.path);
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase);
        let mut sub = match ext.as_deref() {
            Some("gltf" | "glb") => {
                let options = GltfOptions {
                    reflectance_policy: match inc.clamp_reflectance {
                        Some(max) => ReflectancePolicy::Clamp { max },
                        None => ReflectancePolicy::Reject,
                    },
                    grouping: options.grouping,
                    ..GltfOptions::default()
                };
                load_gltf(&path, &options)?
            }
            Some("toml") => load_native_rec(&path, stack, options)?,
            _ => {
                return Err(SceneError::UnknownFormat {
                    file: path.display().to_string(),
                });
            }
        };
        if inc.scale.is_some() || inc.translate.is_some() {
            let s = inc.scale.unwrap_or(1.0);
            let t = DVec3::from_array(inc.translate.unwrap_or([0.0; 3]));
            if !(s.is_finite() && s > 0.0 && t.is_finite()) {
                return Err(SceneError::Malformed {
                    file: file.into(),
                    element,
                    what: "include scale must be finite and > 0, translate finite".into(),
                });
            }
            let m =
                DMat4::from_scale_rotation_translation(DVec3::splat(s), glam::DQuat::IDENTITY, t);
            transform_scene(&mut sub, &m);
        }
        scene.merge(sub, &inc.prefix);
    }
    Ok(())
}

/// `[[material]]`: Lambertian materials with optional emission profile and Ward lobe.
fn add_materials(scene: &mut Scene, spec: &FileSpec, file: &str) -> Result<(), SceneError> {
    for m in &spec.material {
        if scene.material_id(&m.name).is_some() {
            return Err(SceneError::DuplicateName {
                file: file.into(),
                kind: "material".into(),
                name: m.name.clone(),
            });
        }
        let mut mat = Material::lambertian(
            m.name.clone(),
            m.reflectance.rgb(),
            m.emission.map_or(Rgb::BLACK, ColorSpec::rgb),
        );
        if let Some(n) = m.emission_exponent {
            mat.emission_profile = EmissionProfile::CosinePower { exponent: n };
        }
        if let Some(w) = &m.ward {
            mat.ward = Some(WardParams {
                specular: w.specular.rgb(),
                alpha_x: w.alpha_x,
                alpha_y: w.alpha_y.unwrap_or(w.alpha_x),
            });
        }
        mat.validate(file)?;
        scene.add_material(mat);
    }
    Ok(())
}

/// `[[surface]]`: shapes with their materials; meshes grouped into complex polygons
/// when the options ask for it (loader warnings recorded on the scene).
fn add_surfaces(
    scene: &mut Scene,
    spec: &FileSpec,
    file: &str,
    options: &LoadOptions,
) -> Result<(), SceneError> {
    for s in &spec.surface {
        let element = format!("surface {:?}", s.name);
        if scene.surface(&s.name).is_some() {
            return Err(SceneError::DuplicateName {
                file: file.into(),
                kind: "surface".into(),
                name: s.name.clone(),
            });
        }
        let lookup = |name: &str| {
            scene
                .material_id(name)
                .ok_or_else(|| SceneError::UnknownReference {
                    file: file.into(),
                    element: element.clone(),
                    kind: "material".into(),
                    name: name.into(),
                })
        };
        let material = lookup(&s.material)?;
        let sides = match &s.back_material {
            Some(b) => Sidedness::TwoSided { back: lookup(b)? },
            None => Sidedness::OneSided,
        };
        let (shape, dropped) = shape_of(&s.shape, file, &element)?;
        if dropped > 0 {
            scene.warnings.push(Warning {
                file: file.into(),
                element: element.clone(),
                kind: WarningKind::DegenerateTrianglesDropped { count: dropped },
            });
        }
        // Zero or non-finite area is an error here (never a surface dropped).
        shape.validate(file, &element)?;
        let tangent = s.tangent.map(DVec3::from_array);
        if let Some(t) = tangent
            && !(t.is_finite() && t.length() > 0.0)
        {
            return Err(SceneError::Malformed {
                file: file.into(),
                element,
                what: format!("tangent {t} must be finite and non-zero"),
            });
        }
        let parts = match shape {
            Shape::Mesh(m) if options.grouping == MeshGrouping::Surfaces => {
                let grouped = group_mesh(&m, file, &element)?;
                for kind in grouped.warnings {
                    scene.warnings.push(Warning {
                        file: file.into(),
                        element: element.clone(),
                        kind,
                    });
                }
                grouped.parts
            }
            shape => vec![MeshPart {
                suffix: String::new(),
                shape,
                reversed: false,
            }],
        };
        for part in parts {
            let name = format!("{}{}", s.name, part.suffix);
            if scene.surface(&name).is_some() {
                return Err(SceneError::DuplicateName {
                    file: file.into(),
                    kind: "surface".into(),
                    name,
                });
            }
            if let Some(t) = tangent {
                scene.tangents.insert(name.clone(), t);
            }
            let (material, sides) = if part.reversed {
                reversed_sides(scene, material, sides)
            } else {
                (material, sides)
            };
            scene.surfaces.push(Surface {
                name,
                shape: part.shape,
                material,
                sides,
            });
        }
    }
    Ok(())
}

/// `[[medium]]`: participating media with their grids (files relative to `base`).
fn add_media(
    scene: &mut Scene,
    spec: &FileSpec,
    file: &str,
    base: Option<&Path>,
) -> Result<(), SceneError> {
    for m in &spec.medium {
        if scene.media.iter().any(|x| x.name == m.name) {
            return Err(SceneError::DuplicateName {
                file: file.into(),
                kind: "medium".into(),
                name: m.name.clone(),
            });
        }
        let n = m
            .resolution
            .iter()
            .try_fold(1usize, |a, &k| a.checked_mul(k))
            .filter(|&n| n <= MAX_VOXELS)
            .ok_or_else(|| SceneError::Malformed {
                file: file.into(),
                element: format!("medium {:?}", m.name),
                what: format!("resolution {:?} exceeds {MAX_VOXELS} voxels", m.resolution),
            })?;
        let dir = base.unwrap_or(Path::new("."));
        let element = |g: &str| format!("medium {:?} {g}", m.name);
        let medium = Medium {
            name: m.name.clone(),
            min: DVec3::from_array(m.min),
            max: DVec3::from_array(m.max),
            resolution: m.resolution,
            source: grid(&m.source, n, dir, file, &element("source"), false)?,
            opacity: grid(&m.opacity, n, dir, file, &element("opacity"), true)?
                .into_iter()
                .map(|c| c.0[0])
                .collect(),
            albedo: grid(&m.albedo, n, dir, file, &element("albedo"), false)?,
        };
        medium.validate(file)?;
        scene.media.push(medium);
    }
    Ok(())
}

/// `[[camera]]`: look-at cameras.
fn add_cameras(scene: &mut Scene, spec: &FileSpec, file: &str) -> Result<(), SceneError> {
    for c in &spec.camera {
        let cam = Camera::look_at(
            c.name.clone(),
            DVec3::from_array(c.position),
            DVec3::from_array(c.target),
            DVec3::from_array(c.up.unwrap_or([0.0, 1.0, 0.0])),
            c.yfov_deg.to_radians(),
            c.aspect,
        )
        .filter(|_| c.aspect.is_none_or(|a| a.is_finite() && a > 0.0))
        .ok_or_else(|| SceneError::Malformed {
            file: file.into(),
            element: format!("camera {:?}", c.name),
            what: "degenerate view (position = target, up parallel to view, non-finite values, or yfov outside (0, 180))".into(),
        })?;
        scene.cameras.push(cam);
    }
    Ok(())
}

/// Applies a translate + uniform scale `m` to every surface, medium and camera of an
/// included scene.
fn transform_scene(scene: &mut Scene, m: &DMat4) {
    for surf in &mut scene.surfaces {
        if let Some(t) = surf.shape.transformed(m) {
            surf.shape = t;
        }
    }
    for med in &mut scene.media {
        med.min = m.transform_point3(med.min);
        med.max = m.transform_point3(med.max);
        // Opacity is per voxel and survives scaling; the source term is power per unit
        // volume, so the total emitted power scales with s³ (the medium is resized).
    }
    for cam in &mut scene.cameras {
        cam.position = m.transform_point3(cam.position);
    }
    for light in &mut scene.lights {
        if let Some(l) = light.transformed(m) {
            *light = l;
        }
    }
}
