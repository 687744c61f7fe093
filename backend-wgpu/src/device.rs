//! Devices opened and destroyed one at a time in the process.
//!
//! On an NVIDIA H100 (Vulkan, driver 580.159.04, Debian's loader 1.3.239) the wgpu tests hung
//! whenever they ran on more than two threads: one thread was inside `vkDestroyDevice`, waiting
//! in the driver, while the others waited in `vkCreateDevice` and `vkDestroyDevice` for the
//! loader's lock (backtraces taken with `cuda-gdb` there). One thread at a time passed every
//! test. The Vulkan loader also walks its list of devices while other threads may add to it
//! or free from it (<https://github.com/KhronosGroup/Vulkan-Loader/issues/2018>), so
//! concurrent creation and destruction is unsafe below us whatever the driver. Every device this crate opens is
//! therefore opened by [`open`] and destroyed when the last [`SerialDevice`] holding it drops,
//! both under one process-wide lock; gathers on devices already open still run side by side.

use std::sync::{Mutex, MutexGuard, PoisonError};

static LIFECYCLE: Mutex<()> = Mutex::new(());

fn lifecycle() -> MutexGuard<'static, ()> {
    LIFECYCLE.lock().unwrap_or_else(PoisonError::into_inner)
}

/// A wgpu device and its queue whose destruction waits for the process-wide lock.
///
/// wgpu destroys a device when the last handle to it or to any of its resources drops, so an
/// owner must keep a `SerialDevice` until its buffers, pipelines and bind groups are gone: a
/// struct declares it last (fields drop in order), a function binds it first (locals drop in
/// reverse). Clones share the device; whichever drops last destroys it, under the lock.
#[derive(Clone, Debug)]
pub(crate) struct SerialDevice {
    /// `None` only inside `drop`.
    inner: Option<(wgpu::Device, wgpu::Queue)>,
}

impl SerialDevice {
    pub(crate) fn device(&self) -> &wgpu::Device {
        &self.inner.as_ref().expect("taken only by drop").0
    }

    pub(crate) fn queue(&self) -> &wgpu::Queue {
        &self.inner.as_ref().expect("taken only by drop").1
    }
}

impl Drop for SerialDevice {
    fn drop(&mut self) {
        let _one_at_a_time = lifecycle();
        drop(self.inner.take());
    }
}

/// Opens a device on `adapter` under the process-wide lock.
pub(crate) fn open(
    adapter: &wgpu::Adapter,
    descriptor: &wgpu::DeviceDescriptor<'_>,
) -> Result<SerialDevice, wgpu::RequestDeviceError> {
    let _one_at_a_time = lifecycle();
    let pair = pollster::block_on(adapter.request_device(descriptor))?;
    Ok(SerialDevice { inner: Some(pair) })
}

/// Maps `buffer` (with `MAP_READ`, its copy already submitted) for reading and waits for it;
/// `what` names the failure.
pub(crate) fn map_read_and_wait(
    device: &wgpu::Device,
    buffer: &wgpu::Buffer,
    what: &str,
) -> Result<(), crate::GpuError> {
    use crate::GpuError;
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| GpuError::Device(format!("{what}: {e}")))?;
    rx.recv()
        .map_err(|_| GpuError::Device(format!("{what}: the readback callback never ran")))?
        .map_err(|e| GpuError::Device(format!("{what}: readback failed: {e}")))
}
