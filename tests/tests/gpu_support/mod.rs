//! The adapters the wgpu tests run on, shared by the own-device and host-device tests.

use radiosity_backend_wgpu::{Adapter, adapters};

/// Every adapter but GL ones (all GL ones if there is nothing else), or none when there is
/// none and this is not CI (a note is printed). Under `CI=true` no adapter is a failure:
/// `scripts/test.sh` installs the software Vulkan driver.
pub(crate) fn gpu_adapters() -> Vec<Adapter> {
    let list = adapters();
    if list.iter().any(|a| a.info.backend != "gl") {
        return list
            .into_iter()
            .filter(|a| a.info.backend != "gl")
            .collect();
    }
    if list.is_empty() {
        let ci = std::env::var("CI").is_ok_and(|v| v == "true");
        assert!(
            !ci,
            "CI=true but wgpu finds no adapter: scripts/test.sh installs mesa-vulkan-drivers and libvulkan1"
        );
        eprintln!("no GPU adapter (install mesa-vulkan-drivers libvulkan1): skipping");
    }
    list
}
