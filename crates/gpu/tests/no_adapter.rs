//! Without a Vulkan driver, opening a device is a typed `GpuError::NoAdapter` naming
//! the fix, never a panic. The check runs in a child process (this test binary
//! re-invoked) whose loader is pointed at a driver manifest that does not exist.

use std::process::Command;

use wavelux_gpu::{Gpu, GpuError};

const CHILD: &str = "WAVELUX_GPU_NO_ADAPTER_CHILD";

#[test]
fn missing_driver_is_a_typed_error() {
    if std::env::var(CHILD).is_ok() {
        // In the child: no driver can load.
        let err = Gpu::new().expect_err("no adapter without a driver");
        assert!(matches!(err, GpuError::NoAdapter { .. }), "{err:?}");
        let msg = err.to_string();
        assert!(
            msg.contains("no GPU adapter found") && msg.contains("mesa-vulkan-drivers"),
            "{msg}"
        );
        assert!(wavelux_gpu::adapters().is_empty());
        return;
    }
    let exe = std::env::current_exe().expect("test binary path");
    let missing = std::env::temp_dir().join("wavelux-no-such-vulkan-driver.json");
    let out = Command::new(exe)
        .args(["missing_driver_is_a_typed_error", "--exact", "--nocapture"])
        .env(CHILD, "1")
        .env("VK_DRIVER_FILES", &missing)
        .env("VK_ICD_FILENAMES", &missing)
        .env_remove("WGPU_ADAPTER_NAME")
        .output()
        .expect("child test runs");
    let text =
        String::from_utf8_lossy(&out.stderr).into_owned() + &String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "child failed:\n{text}");
    assert!(
        text.contains("1 passed"),
        "child did not run the check:\n{text}"
    );
}

#[test]
fn a_filter_matching_no_adapter_is_a_typed_error() {
    let err = Gpu::with_filter(Some("no adapter is called this 7f3a")).expect_err("no match");
    match err {
        GpuError::NoAdapter { filter } => {
            assert_eq!(filter.as_deref(), Some("no adapter is called this 7f3a"))
        }
        e => panic!("{e:?}"),
    }
}
