//! Adapter discovery for the GPU tests: every test runs on every adapter and prints
//! its name; with none it prints `SKIPPED: no wgpu adapter` and passes, unless
//! `WAVELUX_REQUIRE_ADAPTER=1` (CI), where it fails.

use std::sync::{Arc, OnceLock};

use wavelux_gpu::{Gpu, adapters};

/// The devices of every adapter, opened once per test binary: the tests share them
/// (wgpu devices are thread-safe, error scopes are per thread), so each shader is
/// compiled once per binary (`Gpu`'s pipeline cache), not once per test.
fn opened() -> &'static [(String, Arc<Gpu>)] {
    static GPUS: OnceLock<Vec<(String, Arc<Gpu>)>> = OnceLock::new();
    GPUS.get_or_init(|| {
        let mut out = Vec::new();
        for a in &adapters() {
            match Gpu::with_filter(Some(&a.name)) {
                Ok(g) => out.push((
                    format!(
                        "adapter {} ({}, {}, driver {})",
                        a.name, a.device_type, a.backend, a.driver
                    ),
                    g,
                )),
                Err(e) => eprintln!("adapter {} failed to open: {e}", a.name),
            }
        }
        out
    })
}

/// One open device per adapter (empty, after the skip notice, when there is none).
pub fn gpus(test: &str) -> Vec<Arc<Gpu>> {
    let out: Vec<Arc<Gpu>> = opened()
        .iter()
        .map(|(name, g)| {
            eprintln!("{test}: {name}");
            g.clone()
        })
        .collect();
    if out.is_empty() {
        assert!(
            std::env::var("WAVELUX_REQUIRE_ADAPTER").as_deref() != Ok("1"),
            "{test}: no wgpu adapter, and WAVELUX_REQUIRE_ADAPTER=1"
        );
        eprintln!("{test}: SKIPPED: no wgpu adapter");
    }
    out
}
