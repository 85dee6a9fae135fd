//! wavelux-gpu: the wgpu backend of issue 17. It implements the device-independent
//! backend traits of the crates that own the CPU algorithms:
//!
//! - [`GpuOcclusion`]: [`wavelux_geometry::backend::OcclusionBackend`] — two-point
//!   visibility (Ziegler §2.4) by CWBVH traversal (Ylitie et al. 2017) with f32 leaf
//!   tests that answer *blocked*, *clear* or *unsure*; unsure rays are re-traced by
//!   [`wavelux_geometry::Accel::occluded`], so answers equal the CPU's exactly
//!   ([`mod@occlusion`] derives the error bounds).
//! - [`GpuMatVec`]: [`wavelux_linear::backend::MatVecBackend`] — dense and
//!   block-sparse matrix–vector products in power-of-two-scaled f32 with compensated
//!   (TwoSum) sums in a fixed order, within `1e-6·(|A||x|)ᵢ + 1e-30·max|A|·max|x|` of
//!   the f64 reference ([`mod@matvec`]).
//! - [`GpuProjector`]: [`wavelux_volume::Projector`] — the global cube's projection
//!   (GlobalCube §3.1–3.2) as a compute pass: the CPU projector's exact
//!   one-ray-per-pixel projection in f32, within 1e-5 of it where the projection is
//!   continuous in the ray; rays through cell edges are discussed in
//!   [`mod@projector`].
//!
//! - [`GpuTransfer`]: [`wavelux_meshless::TransferBackend`] — the meshless relighting
//!   product `i = S·e` (Meshless §3.3) on the shared packed layout, TwoSum pairs in a
//!   fixed order, within `1e-6·(|S||e|) + 1e-30·max|S|·max|e|` of the CPU backend
//!   ([`mod@transfer`]).
//!
//! [`Gpu`] selects the adapter (`WGPU_ADAPTER_NAME` substring, else discrete >
//! integrated > virtual > cpu, e.g. Mesa lavapipe), requests the adapter's own
//! limits, and turns every wgpu failure (validation, out of memory, device loss) into
//! a typed [`GpuError`]: error scopes around each submission and an uncaptured-error
//! handler that records instead of panicking.
//!
//! The CPU stays the default and the reference: no method crate depends on this one;
//! the `wavelux` facade wires it behind `--device`. wgpu is built with
//! `default-features = false` and only `std, parking_lot, wgsl, vulkan`. No `unsafe`
//! code is used (the workspace lint stays `deny`).

pub mod device;
pub mod matvec;
pub mod occlusion;
pub mod projector;
pub mod transfer;

pub use device::{AdapterSummary, Gpu, adapters};
pub use matvec::GpuMatVec;
pub use occlusion::GpuOcclusion;
pub use projector::GpuProjector;
pub use transfer::GpuTransfer;

/// Errors of the GPU backend.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum GpuError {
    /// No adapter (or none matching `WGPU_ADAPTER_NAME`) was found.
    #[error(
        "no GPU adapter found{}(install mesa-vulkan-drivers for a software one)",
        match filter { Some(f) => format!(" matching WGPU_ADAPTER_NAME={f:?} "), None => " ".to_owned() }
    )]
    NoAdapter {
        /// The `WGPU_ADAPTER_NAME` filter, if one was set.
        filter: Option<String>,
    },
    /// Requesting the device failed.
    #[error("adapter {adapter}: device request failed: {message}")]
    RequestDevice {
        /// Adapter name.
        adapter: String,
        /// wgpu's message.
        message: String,
    },
    /// A validation error, an out-of-memory error or a device loss during work.
    #[error("adapter {adapter}: {message}")]
    Device {
        /// Adapter name.
        adapter: String,
        /// What failed.
        message: String,
    },
    /// The input does not fit the device's limits (buffer binding size, dispatch size).
    #[error("adapter {adapter}: {what} needs {needed} bytes, the device binds at most {limit}")]
    TooLarge {
        /// Adapter name.
        adapter: String,
        /// Which buffer.
        what: &'static str,
        /// Bytes needed.
        needed: u64,
        /// The binding limit.
        limit: u64,
    },
}

impl GpuError {
    fn parts(&self) -> (String, String) {
        match self {
            GpuError::NoAdapter { .. } => ("none".to_owned(), self.to_string()),
            GpuError::RequestDevice { adapter, .. }
            | GpuError::Device { adapter, .. }
            | GpuError::TooLarge { adapter, .. } => (adapter.clone(), self.to_string()),
        }
    }
}

impl From<GpuError> for wavelux_geometry::GeometryError {
    fn from(e: GpuError) -> Self {
        let (device, message) = e.parts();
        wavelux_geometry::GeometryError::Backend { device, message }
    }
}

impl From<GpuError> for wavelux_linear::LinearError {
    fn from(e: GpuError) -> Self {
        let (device, message) = e.parts();
        wavelux_linear::LinearError::Backend { device, message }
    }
}

impl From<GpuError> for wavelux_volume::VolumeError {
    fn from(e: GpuError) -> Self {
        let (device, message) = e.parts();
        wavelux_volume::VolumeError::Backend {
            backend: format!("gpu ({device})"),
            reason: message,
        }
    }
}
