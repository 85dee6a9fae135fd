//! Adapter discovery for the GPU tests: every test runs on every adapter and prints
//! its name; with none it prints `SKIPPED: no wgpu adapter` and passes, unless
//! `WAVELUX_REQUIRE_ADAPTER=1` (CI), where it fails.

use std::sync::Arc;

use wavelux_gpu::{Gpu, adapters};

/// One open device per adapter (empty, after the skip notice, when there is none).
pub fn gpus(test: &str) -> Vec<Arc<Gpu>> {
    let list = adapters();
    let mut out = Vec::new();
    for a in &list {
        match Gpu::with_filter(Some(&a.name)) {
            Ok(g) => {
                eprintln!(
                    "{test}: adapter {} ({}, {}, driver {})",
                    a.name, a.device_type, a.backend, a.driver
                );
                out.push(g);
            }
            Err(e) => eprintln!("{test}: adapter {} failed to open: {e}", a.name),
        }
    }
    if out.is_empty() {
        assert!(
            std::env::var("WAVELUX_REQUIRE_ADAPTER").as_deref() != Ok("1"),
            "{test}: no wgpu adapter, and WAVELUX_REQUIRE_ADAPTER=1"
        );
        eprintln!("{test}: SKIPPED: no wgpu adapter");
    }
    out
}
