//! Adapter selection, the device, buffer helpers and error capture.
//!
//! Selection: every Vulkan adapter is enumerated; if `WGPU_ADAPTER_NAME` is set, only
//! adapters whose name contains it (case-insensitive) qualify — matched here, because
//! wgpu's own helper panics on a miss. Among those, discrete > integrated > virtual >
//! cpu > other, ties in enumeration order. The device is requested with the
//! adapter's own limits (lavapipe binds storage buffers of up to 128 MiB).
//!
//! Errors: every batch of work runs inside validation, out-of-memory and internal
//! error scopes ([`Gpu::scoped`]); anything escaping them reaches an
//! uncaptured-error handler that records the message instead of panicking, and a
//! device loss is recorded by the device-lost callback. Both turn into
//! [`GpuError::Device`] at the next check.

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

use wgpu::util::DeviceExt;

use crate::GpuError;

/// What the JSON summary reports of an adapter.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AdapterSummary {
    /// Adapter name (e.g. "llvmpipe (LLVM 15.0.6, 256 bits)").
    pub name: String,
    /// "discrete", "integrated", "virtual", "cpu" or "other".
    pub device_type: String,
    /// Graphics API ("vulkan").
    pub backend: String,
    /// Driver name and version.
    pub driver: String,
}

impl AdapterSummary {
    fn of(info: &wgpu::AdapterInfo) -> AdapterSummary {
        AdapterSummary {
            name: info.name.clone(),
            device_type: device_type_name(info.device_type).to_owned(),
            backend: format!("{:?}", info.backend).to_lowercase(),
            driver: format!("{} {}", info.driver, info.driver_info)
                .trim()
                .to_owned(),
        }
    }

    /// True for discrete and integrated GPUs (what `--device auto` accepts).
    pub fn is_hardware(&self) -> bool {
        self.device_type == "discrete" || self.device_type == "integrated"
    }
}

fn device_type_name(t: wgpu::DeviceType) -> &'static str {
    match t {
        wgpu::DeviceType::DiscreteGpu => "discrete",
        wgpu::DeviceType::IntegratedGpu => "integrated",
        wgpu::DeviceType::VirtualGpu => "virtual",
        wgpu::DeviceType::Cpu => "cpu",
        wgpu::DeviceType::Other => "other",
    }
}

fn rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

fn instance() -> wgpu::Instance {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = wgpu::Backends::VULKAN;
    wgpu::Instance::new(desc)
}

/// Every adapter wgpu can see (Vulkan), in enumeration order.
pub fn adapters() -> Vec<AdapterSummary> {
    pollster::block_on(instance().enumerate_adapters(wgpu::Backends::VULKAN))
        .iter()
        .map(|a| AdapterSummary::of(&a.get_info()))
        .collect()
}

/// An open device on the selected adapter.
#[derive(Debug)]
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    summary: AdapterSummary,
    limits: wgpu::Limits,
    errors: Arc<Mutex<Vec<String>>>,
    /// Compute pipelines built so far, by label and entry point (each label names one
    /// WGSL source of this crate): a shader is compiled once per device, however many
    /// kernels objects use it (about a second per pipeline on lavapipe).
    pipelines: Mutex<HashMap<(String, String), wgpu::ComputePipeline>>,
}

impl Gpu {
    /// Opens the adapter chosen by the module's rules (`WGPU_ADAPTER_NAME` read from
    /// the environment).
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] or [`GpuError::RequestDevice`].
    pub fn new() -> Result<Arc<Gpu>, GpuError> {
        let filter = std::env::var("WGPU_ADAPTER_NAME")
            .ok()
            .filter(|s| !s.is_empty());
        Gpu::with_filter(filter.as_deref())
    }

    /// Opens the best adapter whose name contains `filter` (case-insensitive), or the
    /// best of all when `None`.
    ///
    /// # Errors
    /// [`GpuError::NoAdapter`] or [`GpuError::RequestDevice`].
    pub fn with_filter(filter: Option<&str>) -> Result<Arc<Gpu>, GpuError> {
        let inst = instance();
        let mut list = pollster::block_on(inst.enumerate_adapters(wgpu::Backends::VULKAN));
        if let Some(f) = filter {
            let f = f.to_lowercase();
            list.retain(|a| a.get_info().name.to_lowercase().contains(&f));
        }
        // Stable: ties keep enumeration order.
        list.sort_by_key(|a| rank(a.get_info().device_type));
        let Some(adapter) = list.into_iter().next() else {
            return Err(GpuError::NoAdapter {
                filter: filter.map(str::to_owned),
            });
        };
        let info = adapter.get_info();
        let summary = AdapterSummary::of(&info);
        let limits = adapter.limits();
        let desc = wgpu::DeviceDescriptor {
            label: Some("wavelux"),
            required_features: wgpu::Features::empty(),
            required_limits: limits.clone(),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&desc)).map_err(|e| {
            GpuError::RequestDevice {
                adapter: summary.name.clone(),
                message: e.to_string(),
            }
        })?;
        let errors = Arc::new(Mutex::new(Vec::new()));
        let sink = errors.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            if let Ok(mut v) = sink.lock() {
                v.push(e.to_string());
            }
        }));
        let sink = errors.clone();
        device.set_device_lost_callback(move |reason, msg| {
            if let Ok(mut v) = sink.lock() {
                v.push(format!("device lost ({reason:?}): {msg}"));
            }
        });
        Ok(Arc::new(Gpu {
            device,
            queue,
            summary,
            limits,
            errors,
            pipelines: Mutex::new(HashMap::new()),
        }))
    }

    /// The adapter's name, type, API and driver.
    pub fn adapter(&self) -> &AdapterSummary {
        &self.summary
    }

    /// Largest storage-buffer binding (bytes).
    pub fn max_binding(&self) -> u64 {
        self.limits
            .max_storage_buffer_binding_size
            .min(self.limits.max_buffer_size)
    }

    pub(crate) fn device(&self) -> &wgpu::Device {
        &self.device
    }

    pub(crate) fn queue(&self) -> &wgpu::Queue {
        &self.queue
    }

    pub(crate) fn fail(&self, message: impl Into<String>) -> GpuError {
        GpuError::Device {
            adapter: self.summary.name.clone(),
            message: message.into(),
        }
    }

    /// Runs `f` inside validation, out-of-memory and internal error scopes; any error
    /// captured there, or recorded by the uncaptured-error handler, becomes a
    /// [`GpuError::Device`].
    pub(crate) fn scoped<T>(&self, f: impl FnOnce() -> Result<T, GpuError>) -> Result<T, GpuError> {
        let internal = self.device.push_error_scope(wgpu::ErrorFilter::Internal);
        let oom = self.device.push_error_scope(wgpu::ErrorFilter::OutOfMemory);
        let validation = self.device.push_error_scope(wgpu::ErrorFilter::Validation);
        let r = f();
        let mut errs = Vec::new();
        for scope in [validation, oom, internal] {
            if let Some(e) = pollster::block_on(scope.pop()) {
                errs.push(e.to_string());
            }
        }
        if let Ok(mut v) = self.errors.lock() {
            errs.append(&mut v);
        }
        if !errs.is_empty() {
            return Err(self.fail(errs.join("; ")));
        }
        r
    }

    /// A storage buffer holding `data` (at least 16 bytes, so empty inputs bind).
    pub(crate) fn storage(&self, label: &str, data: &[u8], copy_src: bool) -> wgpu::Buffer {
        let mut usage = wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST;
        if copy_src {
            usage |= wgpu::BufferUsages::COPY_SRC;
        }
        if data.len() < 16 {
            let mut padded = data.to_vec();
            padded.resize(16, 0);
            return self
                .device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents: &padded,
                    usage,
                });
        }
        self.device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(label),
                contents: data,
                usage,
            })
    }

    /// An uninitialised buffer of `size` bytes (at least 16).
    pub(crate) fn buffer(&self, label: &str, size: u64, usage: wgpu::BufferUsages) -> wgpu::Buffer {
        self.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(16).next_multiple_of(4),
            usage,
            mapped_at_creation: false,
        })
    }

    /// A compute pipeline for `entry` of the WGSL `source` (auto layout), built once per
    /// device and `(label, entry)`: `label` must name `source` uniquely.
    pub(crate) fn pipeline(&self, label: &str, source: &str, entry: &str) -> wgpu::ComputePipeline {
        let key = (label.to_owned(), entry.to_owned());
        if let Some(p) = self
            .pipelines
            .lock()
            .ok()
            .and_then(|m| m.get(&key).cloned())
        {
            return p;
        }
        let p = self.build_pipeline(label, source, entry);
        if let Ok(mut m) = self.pipelines.lock() {
            m.entry(key).or_insert_with(|| p.clone());
        }
        p
    }

    fn build_pipeline(&self, label: &str, source: &str, entry: &str) -> wgpu::ComputePipeline {
        let module = self
            .device
            .create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(label),
                source: wgpu::ShaderSource::Wgsl(source.into()),
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(label),
                layout: None,
                module: &module,
                entry_point: Some(entry),
                compilation_options: wgpu::PipelineCompilationOptions::default(),
                cache: None,
            })
    }

    /// Submits `encoder`, then copies back `size` bytes (a multiple of 4) of `staging`
    /// (a MAP_READ buffer the encoder copied into) as 32-bit words, and waits. Every
    /// kernel's readback goes through here: the words are decoded from the mapped
    /// bytes one by one (`u32::from_ne_bytes`), never by casting a byte vector, whose
    /// allocation need not be 4-byte aligned.
    pub(crate) fn submit_and_read(
        &self,
        encoder: wgpu::CommandEncoder,
        staging: &wgpu::Buffer,
        size: u64,
    ) -> Result<Vec<u32>, GpuError> {
        self.queue.submit([encoder.finish()]);
        let slice = staging.slice(..size.max(4));
        let (tx, rx) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| self.fail(format!("poll: {e}")))?;
        match rx.recv() {
            Ok(Ok(())) => {}
            Ok(Err(e)) => return Err(self.fail(format!("map: {e}"))),
            Err(_) => return Err(self.fail("map callback dropped")),
        }
        let out = {
            let view = slice
                .get_mapped_range()
                .map_err(|e| self.fail(format!("mapped range: {e}")))?;
            view[..size as usize]
                .chunks_exact(4)
                .map(|w| u32::from_ne_bytes([w[0], w[1], w[2], w[3]]))
                .collect()
        };
        staging.unmap();
        Ok(out)
    }
}

/// Dispatch dimensions for `n` workgroups (x at most 65535, the WebGPU default).
pub(crate) fn dispatch_dims(n: u32) -> (u32, u32) {
    if n <= 65535 {
        (n.max(1), 1)
    } else {
        (65535, n.div_ceil(65535))
    }
}
