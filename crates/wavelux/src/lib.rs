//! wavelux: hierarchical and wavelet global illumination.
//!
//! This facade re-exports the member crates under short names so that an application
//! can depend on `wavelux` alone. Each member crate can also be used on its own.
//!
//! The wgpu backend (module `gpu`, crate `wavelux-gpu`) is behind the `gpu` feature, off by
//! default: without it nothing of wgpu is compiled and the command's `--device gpu`
//! exits with a message naming the feature ([`GPU`] says which build this is).

pub use wavelux_geometry as geometry;
pub use wavelux_glossy as glossy;
#[cfg(feature = "gpu")]
pub use wavelux_gpu as gpu;
pub use wavelux_linear as linear;
pub use wavelux_meshless as meshless;
pub use wavelux_mra as mra;
pub use wavelux_param as param;
pub use wavelux_quadrature as quadrature;
pub use wavelux_render as render;
pub use wavelux_scene as scene;
pub use wavelux_solver as solver;
pub use wavelux_support as support;
pub use wavelux_volume as volume;

/// Whether this build includes the wgpu backend (the `gpu` feature; the module `gpu` exists only
/// then).
pub const GPU: bool = cfg!(feature = "gpu");

/// The member crates, their one-line job, in dependency order (lowest first). Every
/// member is listed whatever the build; `wavelux-gpu` is compiled in only with the
/// `gpu` feature ([`GPU`]).
pub const CRATES: &[(&str, &str)] = &[
    (
        "wavelux-mra",
        "1D MRAs (Haar, multiwavelets, CDV), fast transforms, tensor products",
    ),
    (
        "wavelux-quadrature",
        "Gauss, tensor, singular, masked, triangle, disk and adaptive rules",
    ),
    (
        "wavelux-linear",
        "matrix-free operators and iterative solvers with convergence records",
    ),
    (
        "wavelux-param",
        "parametrized surfaces, equal-area maps, direction maps",
    ),
    (
        "wavelux-geometry",
        "exact primitives, trims, ray intersection, BVH, form factors",
    ),
    (
        "wavelux-scene",
        "scene model, glTF and native loaders, built-in scenes",
    ),
    (
        "wavelux-support",
        "unit-square supports of surfaces and exact trim masks (Virtual Mesh)",
    ),
    (
        "wavelux-solver",
        "wavelet radiosity: hierarchies, links, oracles, gathering and shooting",
    ),
    (
        "wavelux-meshless",
        "meshless hierarchical basis and precomputed direct-to-indirect relighting",
    ),
    (
        "wavelux-glossy",
        "glossy radiance: 4D Haar wavelets, exitant importance, Ward BRDF, final gather",
    ),
    (
        "wavelux-volume",
        "volume radiosity with the hierarchical Global Cube",
    ),
    (
        "wavelux-gpu",
        "wgpu backend: BVH occlusion, matrix-vector and transfer products, global cube",
    ),
    (
        "wavelux-render",
        "cameras, EXR/PNG images, final gather, exports, Monte Carlo reference",
    ),
];
