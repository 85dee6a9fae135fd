//! wavelux-glossy: glossy global illumination with 4D Haar radiance and exitant
//! importance (Christensen, Stollnitz, Salesin, DeRose, "Global Illumination of Glossy
//! Environments Using Wavelets and Importance", ACM TOG 1996 — "Glossy" below).

pub mod error;
pub mod ward;

pub use error::GlossyError;
