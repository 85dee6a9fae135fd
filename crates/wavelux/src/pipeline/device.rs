//! `--device cpu|gpu|auto` (issue 17, "Device selection"): which device runs the
//! method's GPU kernels, and the JSON's `method.device`.
//!
//! - `cpu` (default): the CPU, the reference of every kernel.
//! - `gpu`: any wgpu adapter, software ones (Mesa lavapipe) included. With none, or in
//!   a build without the `gpu` feature, the command exits with status 2
//!   ([`NoDevice`]). A method with no GPU kernel for the chosen settings runs on the
//!   CPU with a `device-fallback` warning (an error with `--strict`).
//! - `auto`: the GPU only when the method has a kernel for the chosen settings and the
//!   adapter is a discrete or integrated GPU (never a software one); otherwise the
//!   CPU, the reason in `method.device.fallback`.
//!
//! A device failure during the run moves the rest of the run to the CPU (same
//! settings, the CPU reference kernel) and is recorded in `fallback`. The kernels
//! wired so far: the global cube's projection (`wavelux_gpu::GpuProjector`, the exact
//! projection with one ray per pixel and receiver sample, 1, 2, 4 or 8 receiver
//! samples per axis, no supersampling,
//! [`FallbackProjector`]), the meshless relighting product `S·e`
//! (`wavelux_gpu::GpuTransfer`, [`DeviceTransfer`]) and the shadow rays of the
//! surface method's transfer blocks (`wavelux_gpu::GpuOcclusion`,
//! [`Device::occlusion`]: recorded, answered in batches and replayed, bitwise the
//! CPU's solution).

use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

#[cfg(any(feature = "gpu", test))]
use wavelux::volume::{
    Collision, Projector, VolumeError,
    backend::{Emission, FaceRgb, GatherStats, ProjectionScene, Receiver},
};

use wavelux::meshless::{CpuBackend, PackedTransfer, TransferBackend, TransferMatrix};

use crate::cli::DeviceArg;
use crate::report::{DeviceInfo, WarningInfo};

/// `--device gpu` found no usable device: the command exits with status 2.
#[derive(Debug)]
pub struct NoDevice(pub String);

impl std::fmt::Display for NoDevice {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "--device gpu: {}", self.0)
    }
}

impl std::error::Error for NoDevice {}

/// The device chosen for one run, and what happened on it.
pub struct Device {
    requested: DeviceArg,
    #[cfg(feature = "gpu")]
    gpu: Option<std::sync::Arc<wavelux::gpu::Gpu>>,
    adapter: Option<[String; 4]>,
    /// Why the CPU runs (chosen before the run, or a device failure during it).
    fallback: Mutex<Option<String>>,
    device_rays: AtomicU64,
    deferred_rays: AtomicU64,
    /// Products (`S·e`) the device computed.
    products: AtomicU64,
}

fn name(d: DeviceArg) -> &'static str {
    match d {
        DeviceArg::Cpu => "cpu",
        DeviceArg::Gpu => "gpu",
        DeviceArg::Auto => "auto",
    }
}

impl Device {
    fn cpu(requested: DeviceArg, fallback: Option<String>) -> Device {
        Device {
            requested,
            #[cfg(feature = "gpu")]
            gpu: None,
            adapter: None,
            fallback: Mutex::new(fallback),
            device_rays: AtomicU64::new(0),
            deferred_rays: AtomicU64::new(0),
            products: AtomicU64::new(0),
        }
    }

    /// The open GPU when the method's kernels run on it.
    #[cfg(feature = "gpu")]
    pub fn gpu(&self) -> Option<std::sync::Arc<wavelux::gpu::Gpu>> {
        if self.on_gpu() {
            self.gpu.clone()
        } else {
            None
        }
    }

    /// Records a device failure: the rest of the run uses the CPU.
    #[cfg(any(feature = "gpu", test))]
    pub fn failed(&self, what: String) {
        if let Ok(mut f) = self.fallback.lock()
            && f.is_none()
        {
            *f = Some(format!("{what}; the rest of the run used the CPU"));
        }
    }

    /// Counts rays traced on the device (`device`) or, after a failure, on the CPU.
    #[cfg(any(feature = "gpu", test))]
    pub fn count(&self, rays: u64, device: bool) {
        let c = if device {
            &self.device_rays
        } else {
            &self.deferred_rays
        };
        c.fetch_add(rays, Ordering::Relaxed);
    }

    /// Whether the method's kernels run on the GPU (until a device failure).
    #[cfg(any(feature = "gpu", test))]
    pub fn on_gpu(&self) -> bool {
        self.adapter.is_some() && self.fallback_reason().is_none()
    }

    /// The occlusion backend of the surface method's transfer blocks
    /// (`wavelux_gpu::GpuOcclusion`) when the run is on the GPU. `--device auto`
    /// declines it when 10 % or more of the scene's primitives are curved (the device
    /// hands every ray reaching a curved box back to the CPU), the reason in
    /// `fallback`.
    pub fn occlusion(
        &self,
        scene: &wavelux::scene::Scene,
    ) -> Option<Box<dyn wavelux::geometry::backend::OcclusionBackend>> {
        #[cfg(feature = "gpu")]
        {
            let gpu = self.gpu()?;
            if self.requested == DeviceArg::Auto {
                let (curved, all) = curved_primitives(scene);
                if curved * 10 >= all && curved > 0 {
                    if let Ok(mut f) = self.fallback.lock() {
                        f.get_or_insert(format!(
                            "{curved} of the scene's {all} primitives are curved (10 % or \
                             more): auto traces on the CPU (--device gpu uses the GPU)"
                        ));
                    }
                    return None;
                }
            }
            Some(Box::new(wavelux::gpu::GpuOcclusion::new(gpu)))
        }
        #[cfg(not(feature = "gpu"))]
        {
            let _ = scene;
            None
        }
    }

    /// Takes a surface solve's device statistics (rays decided on the device, rays
    /// answered on the CPU, the device's first error).
    pub fn record_solve(&self, s: &wavelux::solver::Statistics) {
        self.device_rays.fetch_add(s.device_rays, Ordering::Relaxed);
        self.deferred_rays
            .fetch_add(s.deferred_rays, Ordering::Relaxed);
        if let Some(why) = &s.device_failure
            && let Ok(mut f) = self.fallback.lock()
            && f.is_none()
        {
            *f = Some(format!(
                "device error in the shadow rays: {why}; the rest of the run used the CPU"
            ));
        }
    }

    fn fallback_reason(&self) -> Option<String> {
        self.fallback.lock().ok().and_then(|f| f.clone())
    }

    /// The JSON's `method.device` (after the run: a failure during it is included).
    pub fn info(&self) -> DeviceInfo {
        let fallback = self.fallback_reason();
        let adapter = self.adapter.clone();
        let used = if adapter.is_some() && fallback.is_none() {
            "gpu"
        } else if adapter.is_some()
            && (self.device_rays.load(Ordering::Relaxed) > 0
                || self.products.load(Ordering::Relaxed) > 0)
        {
            "gpu+cpu"
        } else {
            "cpu"
        };
        let [a, t, b, d] = adapter.map_or([None, None, None, None], |v| v.map(Some));
        DeviceInfo {
            requested: name(self.requested).into(),
            used: used.into(),
            adapter: a,
            device_type: t,
            backend: b,
            driver: d,
            fallback,
        }
    }

    /// `statistics.device_rays` and `statistics.deferred_rays` (null when no ray-tracing
    /// GPU kernel ran).
    pub fn rays(&self) -> (Option<u64>, Option<u64>) {
        let (d, c) = (
            self.device_rays.load(Ordering::Relaxed),
            self.deferred_rays.load(Ordering::Relaxed),
        );
        if d == 0 && c == 0 {
            return (None, None);
        }
        (Some(d), Some(c))
    }
}

/// The surface solver's devices for an occlusion backend from
/// [`Device::occlusion`]: the shadow rays on it; the linear solve's gather stays on
/// the CPU, so that the solution is bitwise the CPU's (`wavelux_solver::matvec` would
/// change it within the tolerance).
pub fn backends(
    occlusion: &Option<Box<dyn wavelux::geometry::backend::OcclusionBackend>>,
) -> wavelux::solver::Backends<'_> {
    wavelux::solver::Backends {
        occlusion: occlusion.as_deref(),
        ..Default::default()
    }
}

/// Curved primitives (trimmed and Bézier patches) and all primitives of a scene.
#[cfg(feature = "gpu")]
fn curved_primitives(scene: &wavelux::scene::Scene) -> (usize, usize) {
    use wavelux::geometry::Primitive;
    let (mut curved, mut all) = (0, 0);
    for s in &scene.surfaces {
        for p in s.shape.primitives("scene", &s.name).unwrap_or_default() {
            all += 1;
            curved += usize::from(matches!(p, Primitive::Trimmed(_) | Primitive::Bezier(_)));
        }
    }
    (curved, all)
}

/// Chooses the device of a run: `kernel` says whether the planned method has a GPU
/// kernel for its settings (`Err` says why not).
///
/// # Errors
/// [`NoDevice`] for `--device gpu` without a usable adapter or without the `gpu`
/// feature.
pub fn choose(
    requested: DeviceArg,
    kernel: Result<(), String>,
    warnings: &mut Vec<WarningInfo>,
) -> anyhow::Result<Device> {
    match requested {
        DeviceArg::Cpu => Ok(Device::cpu(requested, None)),
        DeviceArg::Gpu => {
            let dev = open(requested).map_err(NoDevice)?;
            if let Err(why) = kernel {
                let message = format!("--device gpu: {why}; it runs on the CPU");
                warnings.push(WarningInfo {
                    kind: "device-fallback".into(),
                    file: None,
                    element: "--device".into(),
                    message,
                    use_method: None,
                });
                *dev.fallback
                    .lock()
                    .map_err(|_| anyhow::anyhow!("poisoned"))? = Some(why);
            }
            Ok(dev)
        }
        DeviceArg::Auto => {
            if let Err(why) = kernel {
                return Ok(Device::cpu(requested, Some(why)));
            }
            match open(requested) {
                Err(why) => Ok(Device::cpu(requested, Some(why))),
                Ok(dev) => {
                    let hardware = dev
                        .adapter
                        .as_ref()
                        .is_some_and(|a| a[1] == "discrete" || a[1] == "integrated");
                    if !hardware {
                        let a = dev.adapter.clone().unwrap_or_default();
                        *dev.fallback
                            .lock()
                            .map_err(|_| anyhow::anyhow!("poisoned"))? = Some(format!(
                            "the adapter {:?} is a {} device (software or virtual); auto \
                                 uses discrete and integrated GPUs only (--device gpu uses it)",
                            a[0], a[1]
                        ));
                    }
                    Ok(dev)
                }
            }
        }
    }
}

/// Opens the adapter (`WGPU_ADAPTER_NAME` filters by name).
#[cfg(feature = "gpu")]
fn open(requested: DeviceArg) -> Result<Device, String> {
    let gpu = wavelux::gpu::Gpu::new().map_err(|e| e.to_string())?;
    let a = gpu.adapter();
    let adapter = [
        a.name.clone(),
        a.device_type.clone(),
        a.backend.clone(),
        a.driver.clone(),
    ];
    Ok(Device {
        adapter: Some(adapter),
        gpu: Some(gpu),
        ..Device::cpu(requested, None)
    })
}

/// Without the `gpu` feature there is no device to open.
#[cfg(not(feature = "gpu"))]
fn open(_requested: DeviceArg) -> Result<Device, String> {
    Err(
        "this wavelux was built without the `gpu` feature (build it with `cargo build \
         --release --features gpu`)"
            .into(),
    )
}

/// The global cube's projector on the GPU (`G`) with the CPU reference (`C`, same
/// settings) behind it: a device error moves that call and every later one to `C`.
#[cfg(any(feature = "gpu", test))]
pub struct FallbackProjector<'a, G, C> {
    gpu: G,
    cpu: C,
    device: &'a Device,
}

#[cfg(any(feature = "gpu", test))]
impl<'a, G: Projector, C: Projector> FallbackProjector<'a, G, C> {
    /// `gpu` first, `cpu` after a device error; counts rays on `device`.
    pub fn new(gpu: G, cpu: C, device: &'a Device) -> Self {
        Self { gpu, cpu, device }
    }
}

#[cfg(any(feature = "gpu", test))]
impl<G: Projector, C: Projector> Projector for FallbackProjector<'_, G, C> {
    fn name(&self) -> String {
        self.gpu.name()
    }

    fn gather(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        collision: Collision,
        receivers: &[Receiver],
        out: &mut [FaceRgb],
    ) -> Result<GatherStats, VolumeError> {
        if self.device.on_gpu() {
            match self.gpu.gather(scene, emission, collision, receivers, out) {
                Ok(s) => {
                    self.device.count(s.rays, true);
                    return Ok(s);
                }
                Err(e) => self
                    .device
                    .failed(format!("device error in a projection: {e}")),
            }
        }
        let s = self
            .cpu
            .gather(scene, emission, collision, receivers, out)?;
        self.device.count(s.rays, false);
        Ok(s)
    }

    fn escape(
        &self,
        scene: &ProjectionScene<'_>,
        emission: &Emission<'_>,
        framebuffer: u32,
    ) -> Result<[f64; 3], VolumeError> {
        if self.device.on_gpu() {
            match self.gpu.escape(scene, emission, framebuffer) {
                Ok(s) => return Ok(s),
                Err(e) => self
                    .device
                    .failed(format!("device error in the escape pass: {e}")),
            }
        }
        self.cpu.escape(scene, emission, framebuffer)
    }
}

/// The meshless relighting product `S·e` on the chosen device: the GPU backend
/// (`wavelux_gpu::GpuTransfer`) when the run is on the GPU, the CPU backend otherwise
/// and after a device failure (upload or product), which moves the rest of the run to
/// the CPU. The CPU's packed `S` is kept beside the device's for that.
pub struct DeviceTransfer<'a> {
    // Read only by the GPU path (the `gpu` feature).
    #[cfg_attr(not(feature = "gpu"), allow(dead_code))]
    device: &'a Device,
    #[cfg(feature = "gpu")]
    gpu: Option<wavelux::gpu::GpuTransfer>,
}

impl<'a> DeviceTransfer<'a> {
    /// The backend of `device`.
    pub fn new(device: &'a Device) -> Self {
        Self {
            device,
            #[cfg(feature = "gpu")]
            gpu: device.gpu().map(wavelux::gpu::GpuTransfer::new),
        }
    }
}

/// `S` prepared by [`DeviceTransfer`].
pub struct DevicePrepared {
    cpu: PackedTransfer,
    #[cfg(feature = "gpu")]
    gpu: Option<wavelux::gpu::transfer::GpuPreparedTransfer>,
}

/// A failure of the CPU transfer backend (which does not fail).
#[derive(Debug)]
pub struct TransferFailed(String);

impl std::fmt::Display for TransferFailed {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for TransferFailed {}

impl TransferBackend for DeviceTransfer<'_> {
    type Prepared = DevicePrepared;
    type Error = TransferFailed;

    fn name(&self) -> String {
        #[cfg(feature = "gpu")]
        if let Some(g) = &self.gpu
            && self.device.on_gpu()
        {
            return g.name();
        }
        CpuBackend.name()
    }

    fn prepare(&self, s: &TransferMatrix) -> Result<DevicePrepared, TransferFailed> {
        let cpu = CpuBackend
            .prepare(s)
            .map_err(|e| TransferFailed(e.to_string()))?;
        #[cfg(feature = "gpu")]
        let gpu = match &self.gpu {
            Some(g) if self.device.on_gpu() => match g.prepare(s) {
                Ok(p) => Some(p),
                Err(e) => {
                    self.device
                        .failed(format!("device error uploading the transfer matrix: {e}"));
                    None
                }
            },
            _ => None,
        };
        Ok(DevicePrepared {
            cpu,
            #[cfg(feature = "gpu")]
            gpu,
        })
    }

    fn apply(&self, p: &DevicePrepared, e: &[f32], out: &mut [f32]) -> Result<(), TransferFailed> {
        #[cfg(feature = "gpu")]
        if let (Some(g), Some(gp)) = (&self.gpu, &p.gpu)
            && self.device.on_gpu()
        {
            match g.apply(gp, e, out) {
                Ok(()) => {
                    self.device.products.fetch_add(1, Ordering::Relaxed);
                    return Ok(());
                }
                Err(err) => self
                    .device
                    .failed(format!("device error in the transfer product: {err}")),
            }
        }
        CpuBackend
            .apply(&p.cpu, e, out)
            .map_err(|e| TransferFailed(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::AtomicUsize;

    use wavelux::volume::backend::cpu::AntiAlias;
    use wavelux::volume::{CpuProjector, GlobalCubeConfig, Projection, VolumeGrid};

    use super::*;

    /// A "device" that computes like the CPU and fails from its `fail_at`-th call on.
    struct Flaky {
        inner: CpuProjector,
        calls: AtomicUsize,
        fail_at: usize,
    }

    impl Projector for Flaky {
        fn name(&self) -> String {
            "flaky".into()
        }
        fn gather(
            &self,
            scene: &ProjectionScene<'_>,
            emission: &Emission<'_>,
            collision: Collision,
            receivers: &[Receiver],
            out: &mut [FaceRgb],
        ) -> Result<GatherStats, VolumeError> {
            if self.calls.fetch_add(1, Ordering::Relaxed) >= self.fail_at {
                // A failure part-way: garbage in the output, then the error.
                out.iter_mut().for_each(|f| *f = [[f64::NAN; 3]; 6]);
                return Err(VolumeError::Backend {
                    backend: "flaky".into(),
                    reason: "device lost".into(),
                });
            }
            self.inner
                .gather(scene, emission, collision, receivers, out)
        }
        fn escape(
            &self,
            scene: &ProjectionScene<'_>,
            emission: &Emission<'_>,
            framebuffer: u32,
        ) -> Result<[f64; 3], VolumeError> {
            self.inner.escape(scene, emission, framebuffer)
        }
    }

    fn device() -> Device {
        Device {
            adapter: Some([
                "test".into(),
                "discrete".into(),
                "none".into(),
                "none".into(),
            ]),
            ..Device::cpu(DeviceArg::Gpu, None)
        }
    }

    /// A failure at the first call or part-way moves the rest to the CPU, and the
    /// result is the CPU's, bitwise (the "device" here computes exactly as the CPU).
    #[test]
    fn a_device_failure_moves_the_rest_of_the_run_to_the_cpu() -> anyhow::Result<()> {
        let scene = wavelux::scene::builtin::builtin("gc-lounge-8").expect("built-in");
        let grid = VolumeGrid::from_medium(&scene.media[0])?;
        let config = GlobalCubeConfig {
            levels: 1,
            framebuffer: 4,
            tolerance: 1e-3,
            ..GlobalCubeConfig::default()
        };
        let cpu = || CpuProjector::new(Projection::Exact, AntiAlias::OFF);
        let reference = wavelux::volume::solve(&grid, &config, &cpu(), &mut |_| {})?;
        for (fail_at, used) in [(0, "cpu"), (3, "gpu+cpu"), (usize::MAX, "gpu")] {
            let dev = device();
            let flaky = Flaky {
                inner: cpu(),
                calls: AtomicUsize::new(0),
                fail_at,
            };
            let p = FallbackProjector::new(flaky, cpu(), &dev);
            let sol = wavelux::volume::solve(&grid, &config, &p, &mut |_| {})?;
            assert_eq!(
                sol.emission_raw(),
                reference.emission_raw(),
                "fail at {fail_at}"
            );
            let info = dev.info();
            assert_eq!(info.used, used, "fail at {fail_at}");
            let (d, c) = dev.rays();
            match used {
                "cpu" => assert_eq!((d, c.map(|c| c > 0)), (Some(0), Some(true))),
                "gpu+cpu" => assert!(d > Some(0) && c > Some(0), "{d:?} {c:?}"),
                _ => assert!(d > Some(0) && c == Some(0), "{d:?} {c:?}"),
            }
            if used == "gpu" {
                assert!(info.fallback.is_none());
            } else {
                let why = info.fallback.unwrap_or_default();
                assert!(
                    why.contains("device lost") && why.contains("used the CPU"),
                    "{why}"
                );
            }
        }
        Ok(())
    }
}
