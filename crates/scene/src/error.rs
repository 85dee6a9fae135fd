//! Typed errors and warnings of scene construction and loading.
//!
//! Every error names the file it came from (`"<built-in>"` or `"<memory>"` for scenes
//! that have no file) and the element inside it (a glTF `mesh 3 primitive 0`, a native
//! `surface "floor"`, ...), so that a user can find the offending input. Loaders never
//! panic on malformed input: they return one of these variants.

use std::fmt;

/// Name used in errors for scenes built in code.
pub const BUILTIN_FILE: &str = "<built-in>";
/// Name used in errors for scenes parsed from an in-memory buffer without a path.
pub const MEMORY_FILE: &str = "<memory>";

/// Errors raised while building, validating or loading a scene.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum SceneError {
    /// A file could not be read.
    #[error("{file}: cannot read file: {message}")]
    Io {
        /// The file that failed.
        file: String,
        /// The operating-system message.
        message: String,
    },
    /// The file's extension names no supported format.
    #[error("{file}: unknown scene format (expected .gltf, .glb or .toml)")]
    UnknownFormat {
        /// The file.
        file: String,
    },
    /// A glTF document could not be parsed or failed the glTF crate's validation.
    #[error("{file}: invalid glTF: {message}")]
    Gltf {
        /// The file.
        file: String,
        /// The glTF crate's message.
        message: String,
    },
    /// A native (TOML) scene file could not be parsed.
    #[error("{file}: invalid native scene file: {message}")]
    Native {
        /// The file.
        file: String,
        /// The TOML parser's message (with line and column).
        message: String,
    },
    /// The input uses a feature this crate does not support.
    #[error("{file}: {element}: unsupported: {what}")]
    Unsupported {
        /// The file.
        file: String,
        /// The element that uses the feature.
        element: String,
        /// What is unsupported.
        what: String,
    },
    /// The input is structurally broken (missing or inconsistent data).
    #[error("{file}: {element}: malformed: {what}")]
    Malformed {
        /// The file.
        file: String,
        /// The offending element.
        element: String,
        /// What is wrong.
        what: String,
    },
    /// A coordinate or other geometric quantity is NaN or infinite.
    #[error("{file}: {element}: non-finite value {value} in {what}")]
    NonFinite {
        /// The file.
        file: String,
        /// The offending element.
        element: String,
        /// The quantity that holds the value (e.g. "vertex 7").
        what: String,
        /// The offending value.
        value: f64,
    },
    /// A reflectance component is negative, NaN or `>= 1` (a Lambertian reflector with
    /// `ρ >= 1` makes the radiosity operator's Neumann series diverge).
    #[error(
        "{file}: {element}: reflectance component {value} is outside [0, 1) (a Lambertian reflectance must satisfy 0 <= rho < 1)"
    )]
    InvalidReflectance {
        /// The file.
        file: String,
        /// The offending material or texture.
        element: String,
        /// The offending value.
        value: f64,
    },
    /// An emission component is negative, NaN or infinite.
    #[error("{file}: {element}: emission component {value} is negative or not finite")]
    InvalidEmission {
        /// The file.
        file: String,
        /// The offending material or texture.
        element: String,
        /// The offending value.
        value: f64,
    },
    /// A participating-medium value is out of its range.
    #[error("{file}: {element}: {what} value {value} is outside {range}")]
    InvalidMedium {
        /// The file.
        file: String,
        /// The offending medium.
        element: String,
        /// Which grid (`source`, `opacity`, `albedo`).
        what: String,
        /// The offending value.
        value: f64,
        /// The allowed range, in words.
        range: String,
    },
    /// A name refers to nothing (e.g. a surface's material).
    #[error("{file}: {element}: unknown {kind} {name:?}")]
    UnknownReference {
        /// The file.
        file: String,
        /// The element holding the reference.
        element: String,
        /// What kind of thing was referred to (`material`, ...).
        kind: String,
        /// The missing name.
        name: String,
    },
    /// A name is defined twice.
    #[error("{file}: duplicate {kind} name {name:?}")]
    DuplicateName {
        /// The file.
        file: String,
        /// What kind of thing (`surface`, `material`, ...).
        kind: String,
        /// The repeated name.
        name: String,
    },
    /// A surface's whole geometry is degenerate (zero area).
    #[error("{file}: {element}: degenerate geometry: {what}")]
    Degenerate {
        /// The file.
        file: String,
        /// The offending surface.
        element: String,
        /// What is degenerate.
        what: String,
    },
    /// Native files include each other in a cycle, or nest too deep.
    #[error("{file}: include cycle or nesting deeper than {max_depth}: {chain}")]
    IncludeCycle {
        /// The file whose include closes the cycle.
        file: String,
        /// The include chain.
        chain: String,
        /// The nesting limit.
        max_depth: usize,
    },
}

impl SceneError {
    /// The file named by the error.
    pub fn file(&self) -> &str {
        match self {
            Self::Io { file, .. }
            | Self::UnknownFormat { file }
            | Self::Gltf { file, .. }
            | Self::Native { file, .. }
            | Self::Unsupported { file, .. }
            | Self::Malformed { file, .. }
            | Self::NonFinite { file, .. }
            | Self::InvalidReflectance { file, .. }
            | Self::InvalidEmission { file, .. }
            | Self::InvalidMedium { file, .. }
            | Self::UnknownReference { file, .. }
            | Self::DuplicateName { file, .. }
            | Self::Degenerate { file, .. }
            | Self::IncludeCycle { file, .. } => file,
        }
    }
}

/// What a loader dropped or changed without failing.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum WarningKind {
    /// Triangles with (numerically) zero area were dropped; `count` of them.
    DegenerateTrianglesDropped {
        /// How many were dropped.
        count: usize,
    },
    /// A group of connected coplanar triangles was kept as triangles instead of one
    /// polygon, because its boundary could not be made a proper region (mesh
    /// grouping, [`crate::group`]).
    GroupingFallback {
        /// Triangles in the group.
        triangles: usize,
        /// Why, in words.
        reason: String,
    },
    /// Triangles that welding near-duplicate vertices collapsed (two of their vertices
    /// within [`crate::group::WELD_REL`] of the mesh's size) were dropped (mesh
    /// grouping, [`crate::group`]).
    WeldedTrianglesDropped {
        /// How many were dropped.
        count: usize,
        /// Their total area (square scene units).
        area: f64,
    },
    /// A mesh part that nearly tessellates a circle, a cylinder or a sphere was kept
    /// as facets (or a polygon) because one criterion of [`crate::fit`] fails (mesh
    /// grouping, [`crate::group`]): the surface the user may have meant is not the one
    /// modelled.
    CurveNotRecognised {
        /// Triangles of the part.
        triangles: usize,
        /// The surface it nearly is: `disk`, `circular hole`, `arcs`, `cylinder`, `cone`,
        /// `sphere`.
        surface: String,
        /// The failing criterion, with the measured value and the tolerance.
        reason: String,
    },
    /// A reflectance component `>= 1` or `< 0` was clamped (only under
    /// [`crate::ReflectancePolicy::Clamp`]).
    ReflectanceClamped {
        /// The original value.
        from: f64,
        /// The clamped value.
        to: f64,
    },
    /// A glTF primitive that has no area (points or lines) was skipped.
    NonAreaPrimitiveSkipped {
        /// The glTF primitive mode.
        mode: String,
    },
    /// A glTF feature that has no radiometric meaning here was ignored.
    Ignored {
        /// What was ignored.
        what: String,
    },
}

impl WarningKind {
    /// A short stable tag of the kind (`degenerate-triangles-dropped`,
    /// `reflectance-clamped`, `non-area-primitive-skipped`, `ignored`,
    /// `grouping-fallback`, `welded-triangles-dropped`, `curve-not-recognised`), for
    /// machine-readable reports.
    pub fn code(&self) -> &'static str {
        match self {
            Self::DegenerateTrianglesDropped { .. } => "degenerate-triangles-dropped",
            Self::GroupingFallback { .. } => "grouping-fallback",
            Self::WeldedTrianglesDropped { .. } => "welded-triangles-dropped",
            Self::CurveNotRecognised { .. } => "curve-not-recognised",
            Self::ReflectanceClamped { .. } => "reflectance-clamped",
            Self::NonAreaPrimitiveSkipped { .. } => "non-area-primitive-skipped",
            Self::Ignored { .. } => "ignored",
        }
    }
}

/// A non-fatal problem found while loading, with where it happened.
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// The file.
    pub file: String,
    /// The element (surface, glTF mesh primitive, material, ...).
    pub element: String,
    /// What happened.
    pub kind: WarningKind,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}: ", self.file, self.element)?;
        match &self.kind {
            WarningKind::DegenerateTrianglesDropped { count } => {
                write!(f, "dropped {count} degenerate (zero-area) triangle(s)")
            }
            WarningKind::GroupingFallback { triangles, reason } => write!(
                f,
                "kept {triangles} coplanar triangles as triangles, not one polygon: {reason}"
            ),
            WarningKind::WeldedTrianglesDropped { count, area } => write!(
                f,
                "dropped {count} triangle(s) of total area {area:e} that welding near-duplicate vertices collapsed"
            ),
            WarningKind::CurveNotRecognised {
                triangles,
                surface,
                reason,
            } => write!(
                f,
                "kept {triangles} triangles as they are, not as the {surface} they nearly tessellate: {reason}"
            ),
            WarningKind::ReflectanceClamped { from, to } => {
                write!(f, "reflectance {from} clamped to {to}")
            }
            WarningKind::NonAreaPrimitiveSkipped { mode } => {
                write!(f, "skipped primitive with mode {mode} (no area)")
            }
            WarningKind::Ignored { what } => write!(f, "ignored {what}"),
        }
    }
}
