//! Whether the GPU backend can be tested here.

use dvrk_tissue_sim::mpm::gpu::adapter;
use dvrk_tissue_sim::mpm::P2gAtomics;

/// Whether the GPU P2G variant `p2g` can run here; panics under CI when there is no adapter
/// at all (CI installs llvmpipe, so the GPU paths are always tested there).
pub fn ready(p2g: P2gAtomics) -> bool {
    let adapters = adapter::adapters();
    let Some(first) = adapters.first() else {
        let reason = "no GPU adapter (Vulkan/Metal/DX12) found; on Debian/Ubuntu install \
                      mesa-vulkan-drivers for the llvmpipe software adapter";
        if std::env::var_os("CI").is_some() {
            panic!("CI is set and the GPU backend cannot be tested: {reason}");
        }
        println!("skipped: {reason}");
        return false;
    };
    if p2g == P2gAtomics::Float
        && !first
            .features()
            .contains(wgpu::Features::SHADER_FLOAT32_ATOMIC)
    {
        println!(
            "skipped: adapter \"{}\" has no f32 atomics (the fixed-point test covers it)",
            first.get_info().name
        );
        return false;
    }
    true
}
