//! Choosing a GPU adapter, and the device made from it.
//!
//! `auto` takes a hardware adapter (discrete, then integrated, then virtual) and otherwise
//! leaves the scene on the CPU backend, because a software rasteriser (Mesa's llvmpipe) is
//! slower than the rayon solver on the same cores. `gpu` takes a hardware adapter when
//! there is one and a software one otherwise: that is how CI tests the GPU path. The choice
//! and its reason are logged with the adapter's name, API, device type and whether it has
//! f32 atomics.
//!
//! Every adapter comes from one wgpu instance kept for the life of the process
//! ([`instance`]); each world opens (and, dropped, closes) only its own device on it.

use super::GpuError;
use crate::mpm::backend::BackendChoice;
use std::sync::OnceLock;
use wgpu::{Adapter, DeviceType};

/// A device and queue on the chosen adapter.
pub struct GpuContext {
    /// The logical device the solver's buffers and pipelines live on.
    pub device: wgpu::Device,
    /// The device's command queue.
    pub queue: wgpu::Queue,
    /// The adapter's name, backend and type.
    pub info: wgpu::AdapterInfo,
    /// The adapter has (and the device enabled) `SHADER_FLOAT32_ATOMIC`.
    pub float_atomics: bool,
}

/// Whether an adapter of type `t` is hardware (`auto` takes only these).
pub fn is_hardware(t: DeviceType) -> bool {
    matches!(
        t,
        DeviceType::DiscreteGpu | DeviceType::IntegratedGpu | DeviceType::VirtualGpu
    )
}

fn preference(t: DeviceType) -> u32 {
    match t {
        DeviceType::DiscreteGpu => 0,
        DeviceType::IntegratedGpu => 1,
        DeviceType::VirtualGpu => 2,
        DeviceType::Cpu => 3,
        DeviceType::Other => 4,
    }
}

fn describe(a: &Adapter) -> String {
    let info = a.get_info();
    format!(
        "\"{}\" ({:?}, {:?}, f32 atomics: {})",
        info.name,
        info.backend,
        info.device_type,
        if a.features().contains(wgpu::Features::SHADER_FLOAT32_ATOMIC) {
            "yes"
        } else {
            "no"
        }
    )
}

/// The process's wgpu instance on Vulkan, Metal and DX12 (not GL: it has no compute storage
/// atomics worth using), made on first use and never dropped.
///
/// An instance per world made the Vulkan loader load and unload the driver once per world,
/// and NVIDIA's (580, on an H100) takes static TLS (`libnvidia-tls.so`) at each load that
/// glibc does not give back at the unload: the 31st load in a process failed with "cannot
/// allocate memory in static TLS block", the loader found no driver, and that world and every
/// later one failed with "no GPU adapter exists". Kept, the driver is loaded once. Devices
/// are still per world: a dropped world frees its device and buffers on this instance.
pub fn instance() -> &'static wgpu::Instance {
    static INSTANCE: OnceLock<wgpu::Instance> = OnceLock::new();
    INSTANCE.get_or_init(|| {
        wgpu::Instance::new(&wgpu::InstanceDescriptor {
            backends: wgpu::Backends::PRIMARY,
            ..Default::default()
        })
    })
}

/// Every adapter the process's [`instance`] finds, best first.
pub fn adapters() -> Vec<Adapter> {
    let mut list = instance().enumerate_adapters(wgpu::Backends::PRIMARY);
    list.sort_by_key(|a| preference(a.get_info().device_type));
    list
}

/// The first adapter this process opened a device on (see [`describe`]), so that an adapter
/// that stops being listed is not reported as a machine without one.
static OPENED: OnceLock<String> = OnceLock::new();

/// Picks the adapter `choice` asks for: `Ok(None)` means "use the CPU backend".
pub fn select(choice: BackendChoice) -> Result<Option<GpuContext>, GpuError> {
    if choice == BackendChoice::Cpu {
        tracing::info!("backend: cpu (asked for)");
        return Ok(None);
    }
    let list = adapters();
    let found: Vec<String> = list.iter().map(describe).collect();
    let hardware = list.iter().find(|a| is_hardware(a.get_info().device_type));
    let (adapter, why) = match (choice, hardware) {
        (_, Some(a)) => (a, "hardware GPU adapter"),
        (BackendChoice::Auto, None) => {
            tracing::info!(
                "backend: cpu (auto: no hardware GPU adapter; found {})",
                if found.is_empty() {
                    "none".to_string()
                } else {
                    found.join(", ")
                }
            );
            return Ok(None);
        }
        (_, None) => match list.first() {
            Some(a) => (a, "gpu asked for and only a software adapter exists"),
            None => {
                return Err(match OPENED.get() {
                    Some(earlier) => GpuError::AdapterGone(earlier.clone()),
                    None => GpuError::NoAdapter,
                })
            }
        },
    };
    let ctx = open(adapter)?;
    tracing::info!("backend: gpu on {} ({why})", describe(adapter),);
    if let Some(warning) = driver_warning(&ctx.info) {
        tracing::warn!("{warning}");
    }
    Ok(Some(ctx))
}

/// A warning for a driver known to misbehave with this backend. Mesa 22's lavapipe (Debian
/// 12's own) keeps about 100 MB per submitted frame until the device is dropped, measured on
/// the grasp scene; Mesa 25.0's does not.
pub fn driver_warning(info: &wgpu::AdapterInfo) -> Option<String> {
    let mesa_major: u32 = info
        .driver_info
        .split_whitespace()
        .skip_while(|w| *w != "Mesa")
        .nth(1)?
        .split('.')
        .next()?
        .parse()
        .ok()?;
    (info.device_type == DeviceType::Cpu && mesa_major <= 22).then(|| {
        format!(
            "software adapter on {}: this Mesa's lavapipe keeps about 100 MB of memory per \
             frame until the simulation ends; install Mesa 25 or later (on Debian 12: \
             mesa-vulkan-drivers from bookworm-backports)",
            info.driver_info
        )
    })
}

/// Opens a device on `adapter` with its full limits and, where it has them, f32 atomics.
pub fn open(adapter: &Adapter) -> Result<GpuContext, GpuError> {
    let float_atomics = adapter
        .features()
        .contains(wgpu::Features::SHADER_FLOAT32_ATOMIC);
    let required_features = if float_atomics {
        wgpu::Features::SHADER_FLOAT32_ATOMIC
    } else {
        wgpu::Features::empty()
    };
    let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
        label: Some("mpm"),
        required_features,
        required_limits: adapter.limits(),
        ..Default::default()
    }))
    .map_err(|e| GpuError::Device(format!("on adapter {}: {e}", describe(adapter))))?;
    OPENED.get_or_init(|| describe(adapter));
    Ok(GpuContext {
        device,
        queue,
        info: adapter.get_info(),
        float_atomics,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn software(driver_info: &str) -> wgpu::AdapterInfo {
        wgpu::AdapterInfo {
            name: "llvmpipe (LLVM 15.0.6, 256 bits)".into(),
            vendor: 0x10005,
            device: 0,
            device_type: DeviceType::Cpu,
            driver: "llvmpipe".into(),
            driver_info: driver_info.into(),
            backend: wgpu::Backend::Vulkan,
        }
    }

    #[test]
    fn mesa_22_lavapipe_is_warned_of_and_later_mesa_or_hardware_is_not() {
        let old = driver_warning(&software("Mesa 22.3.6 (LLVM 15.0.6)")).unwrap();
        assert!(old.contains("Mesa 22.3.6") && old.contains("bookworm-backports"));
        assert!(driver_warning(&software("Mesa 25.0.7-2~bpo12+1 (LLVM 15.0.6)")).is_none());
        assert!(driver_warning(&software("no version here")).is_none());
        let mut hardware = software("Mesa 22.3.6");
        hardware.device_type = DeviceType::IntegratedGpu;
        assert!(driver_warning(&hardware).is_none());
    }
}
