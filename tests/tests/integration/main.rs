//! Cross-crate ground truth for wavelux: one integration-test binary, one module per
//! topic.

mod catalogue;
mod mra_quadrature;
mod radiosity;
mod scene_gltf;
mod workspace;
