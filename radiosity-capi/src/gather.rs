//! `RadGather`: `y = M · x` over a scene's matrix on a chosen backend, or over a level's
//! systems (`.rad` version 3) lit to the steady state.

use crate::error::{Failure, check_ptr, guard, slice_mut, status};
use crate::scene::{RadScene, read_input};
use crate::{
    RAD_ERR_BACKEND, RAD_ERR_GATHER, RAD_ERR_LENGTH, RAD_ERR_UNAVAILABLE, RAD_ERR_VALUE, RadRgb,
};
use radiosity_backend_wgpu::{Backend, GpuOptions, WgpuLevel};
use radiosity_core::{Gather, GatherError, RadFile, Rgb, TransferMatrix};
use radiosity_runtime::systems::Level;
use std::ffi::{CStr, CString, c_char};

/// The relative change of the exitance in a frame (`Σ|ΔB| / Σ|B|`) at which rad_gather_run
/// calls a level lit: `radiosity solve`'s tolerance.
const LEVEL_TOLERANCE: f32 = 1e-4;
/// The most frames one rad_gather_run gives a level.
const LEVEL_MAX_FRAMES: usize = 100;

/// What a gather runs: one matrix, a level's systems (one gather a system, the light between
/// them on the CPU), or a level on one GPU device (with its systems' patch ranges).
enum Inner {
    One(Box<dyn Gather>),
    Level(Box<Level<Box<dyn Gather>>>),
    Gpu(Box<WgpuLevel>, Vec<std::ops::Range<usize>>),
}

/// A gather over a scene's transfer matrix on one backend, or over a level's systems (each
/// system's matrix on that backend). Opaque: made by rad_gather_new, freed by
/// rad_gather_free; used by one thread at a time.
pub struct RadGather {
    inner: Inner,
    name: CString,
    backend: &'static CStr,
}

impl RadGather {
    fn new(gather: Box<dyn Gather>, backend: &'static CStr) -> Self {
        let name = CString::new(gather.name().replace('\0', " ")).unwrap_or_default();
        Self {
            inner: Inner::One(gather),
            name,
            backend,
        }
    }

    fn systems(&self) -> usize {
        match &self.inner {
            Inner::One(_) => 1,
            Inner::Level(l) => l.count(),
            Inner::Gpu(_, ranges) => ranges.len(),
        }
    }

    fn patches(&self) -> usize {
        match &self.inner {
            Inner::One(g) => g.patches(),
            Inner::Level(l) => l.gathered().len(),
            Inner::Gpu(l, _) => l.gathered().len(),
        }
    }
}

/// A level's gather: every system's matrix on `backend` (each GPU system on a device of its
/// own; "auto" chooses for the first system and the others follow it), its light between
/// systems through the coupling, on the CPU.
fn build_level(file: &RadFile<'_>, backend: &str) -> Result<RadGather, Failure> {
    let mut kind = backend_kind(backend)?;
    if matches!(kind, Backend::Auto | Backend::Gpu) {
        quiet_device_select();
        let options = GpuOptions::default();
        let level = match kind {
            Backend::Gpu => WgpuLevel::new(file, &options)
                .map_err(|e| Failure::new(RAD_ERR_UNAVAILABLE, e.to_string()))
                .map(Some)?,
            // "auto": the GPU where a hardware one is found, else the CPU.
            _ => radiosity_backend_wgpu::auto_level(file, &options).ok(),
        };
        if let Some(level) = level {
            let ranges = file.systems.as_ref().map_or_else(Vec::new, |s| s.ranges());
            let name = CString::new(level.name()).unwrap_or_default();
            return Ok(RadGather {
                inner: Inner::Gpu(Box::new(level), ranges),
                name,
                backend: c"gpu",
            });
        }
        kind = Backend::Cpu;
    }
    let mut ran_on = c"cpu";
    let mut first = None;
    let level = Level::new(file, |s, one| {
        let (g, on) = build_one(&one.matrix.clone().into_owned(), kind)?;
        if s == 0 {
            // The others follow the first system's choice.
            ran_on = on;
            kind = backend_kind(&on.to_string_lossy())?;
            first = Some(g.name().to_owned());
        }
        Ok(g)
    })
    .map_err(
        |e: radiosity_runtime::systems::LevelError<Failure>| match e {
            // A system's gather that could not be made keeps its own status.
            radiosity_runtime::systems::LevelError::Gather(s, f) => {
                Failure::new(f.code, format!("system {s}: {f}"))
            }
            other => Failure::new(RAD_ERR_VALUE, other.to_string()),
        },
    )?;
    let name = format!("{}-systems", first.unwrap_or_default()).replace('\0', " ");
    Ok(RadGather {
        inner: Inner::Level(Box::new(level)),
        name: CString::new(name).unwrap_or_default(),
        backend: ran_on,
    })
}

/// Turns Mesa's Vulkan device-select layer off on a headless machine, once, before the
/// library lists GPU adapters: without a desktop login (`XDG_RUNTIME_DIR` unset or not a
/// directory) the layer prints "XDG_RUNTIME_DIR is invalid" on the host's stderr for every
/// instance, and all it would do is reorder GPUs, which the backend choice ranks itself
/// (docs/decisions/nodevice-select.md). A host that set `NODEVICE_SELECT` keeps its value.
fn quiet_device_select() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        let headless =
            std::env::var_os("XDG_RUNTIME_DIR").is_none_or(|d| !std::path::Path::new(&d).is_dir());
        if headless && std::env::var_os("NODEVICE_SELECT").is_none() {
            // SAFETY: setting a variable races with another thread reading or writing the
            // environment at the same moment. It happens once, on the first GPU gather of a
            // headless process, and the header says so: a host that reads the environment
            // from other threads while it makes its first gather sets NODEVICE_SELECT itself.
            unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
        }
    });
}

fn build(matrix: &TransferMatrix<'static>, backend: &str) -> Result<RadGather, Failure> {
    let kind = backend_kind(backend)?;
    let (gather, name) = build_one(matrix, kind)?;
    Ok(RadGather::new(gather, name))
}

/// The backend a name asks for; RAD_ERR_BACKEND for another name.
fn backend_kind(backend: &str) -> Result<Backend, Failure> {
    Backend::from_name(backend).ok_or_else(|| {
        Failure::new(
            RAD_ERR_BACKEND,
            format!("unknown backend {backend:?}: use auto, cpu, gpu or reference"),
        )
    })
}

/// One matrix's gather on `kind`, with the backend it runs on.
fn build_one(
    matrix: &TransferMatrix<'static>,
    kind: Backend,
) -> Result<(Box<dyn Gather>, &'static CStr), Failure> {
    if matches!(kind, Backend::Auto | Backend::Gpu) {
        quiet_device_select();
    }
    // The command line's choice (radiosity_backend_wgpu::choose).
    let chosen = radiosity_backend_wgpu::choose(kind, matrix.clone(), "requested")
        .map_err(|e| Failure::new(RAD_ERR_UNAVAILABLE, e.to_string()))?;
    let name = match chosen.kind {
        "gpu" => c"gpu",
        "reference" => c"reference",
        _ => c"cpu",
    };
    Ok((chosen.gather, name))
}

/// Makes a gather over `scene`'s matrix on `backend`: "cpu" (the SIMD CPU gather), "gpu" (the
/// wgpu gather on its own device, the best adapter, software rasterisers included), "reference"
/// (the scalar oracle) or "auto" (as the command line chooses: a hardware GPU that can hold
/// the matrix, else the CPU). Writes it to `*out` (NULL on failure) and returns 0, or
/// RAD_ERR_BACKEND for another name, RAD_ERR_UNAVAILABLE when "gpu" finds no usable adapter.
/// Over a level file (its transfer cut into systems, rad_gather_systems above 1): on "gpu"
/// every system's gather and the light between systems run on one device; on "cpu" and
/// "reference" each system gathers on that backend and the light between systems crosses on
/// the CPU; "auto" takes a hardware GPU where there is one, else the CPU
/// (rad_gather_run, rad_gather_frame, rad_gather_update_within).
/// On a machine without a desktop login (XDG_RUNTIME_DIR unset) the first "auto" or "gpu"
/// gather sets NODEVICE_SELECT=1 unless the host set it, so that Mesa's device-select layer
/// keeps quiet on stderr; a host reading the environment from other threads at that moment
/// sets it itself.
/// The scene must outlive the gather.
///
/// # Safety
///
/// `scene` is NULL or a live scene; `backend` is NULL or a NUL-terminated string; `out` is
/// NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_new(
    scene: *const RadScene,
    backend: *const c_char,
    out: *mut *mut RadGather,
) -> i32 {
    status("rad_gather_new", || {
        check_ptr(out.cast_const(), "out")?;
        // SAFETY: `out` is non-NULL and aligned (checked); the caller promises it is writable.
        unsafe { out.write(std::ptr::null_mut()) };
        check_ptr(scene, "scene")?;
        check_ptr(backend, "backend")?;
        // SAFETY: non-NULL and aligned (checked); the caller promises a live scene.
        let scene = unsafe { &*scene };
        // SAFETY: non-NULL (checked); the caller promises a NUL-terminated string.
        let name = unsafe { CStr::from_ptr(backend) }
            .to_str()
            .map_err(|_| Failure::new(RAD_ERR_VALUE, "backend name is not UTF-8"))?;
        let file = &scene.rt.file;
        let gather = if file.systems.is_some() {
            build_level(file, name)?
        } else {
            build(&file.matrix, name)?
        };
        // SAFETY: as above.
        unsafe { out.write(Box::into_raw(Box::new(gather))) };
        Ok(())
    })
}

/// The gather's name as the Gather trait gives it ("cpu-bc1", "gpu-bc1", "reference", ...),
/// owned by the gather; NULL for a NULL gather.
///
/// # Safety
///
/// `gather` is NULL or a live gather.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_name(gather: *const RadGather) -> *const c_char {
    guard("rad_gather_name", std::ptr::null(), || {
        check_ptr(gather, "gather")?;
        // SAFETY: non-NULL and aligned (checked); the caller promises a live gather.
        Ok(unsafe { &*gather }.name.as_ptr())
    })
}

/// The backend the gather runs on, "cpu", "gpu" or "reference" (what "auto" chose), a static
/// string; NULL for a NULL gather.
///
/// # Safety
///
/// `gather` is NULL or a live gather.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_backend(gather: *const RadGather) -> *const c_char {
    guard("rad_gather_backend", std::ptr::null(), || {
        check_ptr(gather, "gather")?;
        // SAFETY: non-NULL and aligned (checked); the caller promises a live gather.
        Ok(unsafe { &*gather }.backend.as_ptr())
    })
}

/// One gather: `y = M · x`, per-patch irradiance (W/m²) from first exitance `x` (W/m²), `n` =
/// the scene's patch count, both in the matrix numbering. `x` and `y` may be the same array.
/// RAD_ERR_VALUE for a negative or non-finite `x` (nothing written), RAD_ERR_GATHER when the backend fails.
/// Over a level, the systems are lit from the light they hold to the steady state (frames
/// until the exitance changes by at most 1e-4 of itself, at most 100; a few frames after a
/// light changes, one when nothing did): `y` is then the one-matrix `M · x` within that
/// tolerance.
///
/// # Safety
///
/// `gather` is NULL or a live gather not in use by another thread; `x` is NULL or `n` readable
/// values; `y` is NULL or `n` writable values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_run(
    gather: *mut RadGather,
    x: *const RadRgb,
    y: *mut RadRgb,
    n: usize,
) -> i32 {
    status("rad_gather_run", || {
        // SAFETY: the caller promises what this function's contract asks.
        let (gather, x, y) = unsafe { gather_args(gather, x, y, n) }?;
        match &mut gather.inner {
            Inner::One(g) => g.gather(&x, y).map_err(failure),
            Inner::Level(level) => {
                level
                    .steady(&x, LEVEL_TOLERANCE, LEVEL_MAX_FRAMES)
                    .map_err(failure)?;
                y.copy_from_slice(level.gathered());
                Ok(())
            }
            Inner::Gpu(level, _) => {
                level
                    .steady(&x, LEVEL_TOLERANCE, LEVEL_MAX_FRAMES)
                    .map_err(gpu_failure)?;
                y.copy_from_slice(level.gathered());
                Ok(())
            }
        }
    })
}

/// The C status of a GPU level's error.
fn gpu_failure(e: radiosity_backend_wgpu::GpuError) -> Failure {
    Failure::new(RAD_ERR_GATHER, e.to_string())
}

/// The C status of a gather error.
fn failure(e: GatherError) -> Failure {
    match e {
        GatherError::Length { .. } => Failure::new(RAD_ERR_LENGTH, e.to_string()),
        GatherError::NonFinite { .. } => Failure::new(RAD_ERR_VALUE, e.to_string()),
        GatherError::Backend(_) => Failure::new(RAD_ERR_GATHER, e.to_string()),
    }
}

/// A gather call's arguments, checked: the gather, `x` and `y`.
type GatherArgs<'a> = (
    &'a mut RadGather,
    std::borrow::Cow<'a, [Rgb]>,
    &'a mut [Rgb],
);

/// Reads a gather call's arguments: the gather, and `x` checked (n patches, each exitance
/// finite and non-negative), copied away from `y`.
///
/// # Safety
///
/// As rad_gather_run's.
unsafe fn gather_args<'a>(
    gather: *mut RadGather,
    x: *const RadRgb,
    y: *mut RadRgb,
    n: usize,
) -> Result<GatherArgs<'a>, Failure> {
    check_ptr(gather.cast_const(), "gather")?;
    // SAFETY: non-NULL and aligned (checked); the caller promises a live gather that no other
    // thread uses.
    let gather = unsafe { &mut *gather };
    let patches = gather.patches();
    if n != patches {
        return Err(Failure::new(
            RAD_ERR_LENGTH,
            format!("n = {n}, the scene has {patches} patches"),
        ));
    }
    // SAFETY: the caller promises `n` readable values at `x`; an overlap with `y` is copied
    // away before `y` is borrowed.
    let x = unsafe { read_input(x, n, y.cast_const(), n, "x") }?;
    if let Some(i) = x
        .iter()
        .position(|v| !(v.is_finite() && v.to_array().iter().all(|c| *c >= 0.0)))
    {
        return Err(Failure::new(
            RAD_ERR_VALUE,
            format!("exitance of patch {i} is negative or not finite"),
        ));
    }
    // SAFETY: the caller promises `n` writable values at a non-NULL `y`; `x` no longer borrows
    // them if they overlapped.
    let y = unsafe { slice_mut(y, n, "y") }?;
    Ok((gather, x, bytemuck::cast_slice_mut(y)))
}

/// One frame of a level: every system updated once (block Gauss–Seidel: each system's own
/// transfer of its first exitance plus the light the others sent it, from their latest
/// exitance), `y` the irradiance after it. The gather keeps the level's light from call to
/// call, so an engine calling it once a frame with the frame's `x` follows the steady state
/// a frame behind (within 1% of it two frames after a light jumps, on a city of 63 011
/// patches). On a one-matrix gather it is rad_gather_run. Arguments and statuses as
/// rad_gather_run's.
///
/// # Safety
///
/// As rad_gather_run.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_frame(
    gather: *mut RadGather,
    x: *const RadRgb,
    y: *mut RadRgb,
    n: usize,
) -> i32 {
    status("rad_gather_frame", || {
        // SAFETY: the caller promises what rad_gather_run's caller does.
        let (gather, x, y) = unsafe { gather_args(gather, x, y, n) }?;
        match &mut gather.inner {
            Inner::One(g) => g.gather(&x, y).map_err(failure),
            Inner::Level(level) => {
                level.systems_mut().frame(&x).map_err(failure)?;
                y.copy_from_slice(level.gathered());
                Ok(())
            }
            Inner::Gpu(level, _) => {
                level.frame(&x).map_err(gpu_failure)?;
                y.copy_from_slice(level.gathered());
                Ok(())
            }
        }
    })
}

/// Systems the gather lights: 1 over a one-matrix file, the level's count over a level file;
/// 0 for a NULL gather.
///
/// # Safety
///
/// `gather` is NULL or a live gather.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_systems(gather: *const RadGather) -> usize {
    guard("rad_gather_systems", 0, || {
        check_ptr(gather, "gather")?;
        // SAFETY: non-NULL and aligned (checked); the caller promises a live gather.
        Ok(unsafe { &*gather }.systems())
    })
}

/// Frees a gather. NULL is a no-op.
///
/// # Safety
///
/// `gather` is NULL or a gather not yet freed; no pointer it returned is used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_free(gather: *mut RadGather) {
    guard("rad_gather_free", (), || {
        if !gather.is_null() {
            // SAFETY: the caller promises a gather from Box::into_raw (rad_gather_new), freed
            // once.
            drop(unsafe { Box::from_raw(gather) });
        }
        Ok(())
    })
}

/// Updates a level's systems most in need first (the change of their own first exitance and
/// of the light the others send them since their last update, times their priority,
/// rad_gather_set_priority) while less than `budget_ms` milliseconds have passed in this call
/// and some system needs an update; `y` is the irradiance after it (systems not updated keep
/// their last light), `*updated` (when not NULL) the systems updated. The frame under a time
/// budget: at least one system when any needs one and `budget_ms` > 0. On a one-matrix gather
/// it is rad_gather_run (one system updated); on a GPU level it is rad_gather_frame (every
/// system updated: one submission, no budget). RAD_ERR_VALUE for a negative or non-finite
/// `budget_ms`; other arguments and statuses as rad_gather_run's.
///
/// # Safety
///
/// As rad_gather_run; `updated` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_update_within(
    gather: *mut RadGather,
    x: *const RadRgb,
    y: *mut RadRgb,
    n: usize,
    budget_ms: f64,
    updated: *mut usize,
) -> i32 {
    status("rad_gather_update_within", || {
        if !(budget_ms.is_finite() && budget_ms >= 0.0) {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("budget_ms must be a finite number of milliseconds ≥ 0, not {budget_ms}"),
            ));
        }
        // SAFETY: the caller promises what rad_gather_run's caller does.
        let (gather, x, y) = unsafe { gather_args(gather, x, y, n) }?;
        let count = match &mut gather.inner {
            Inner::One(g) => {
                g.gather(&x, y).map_err(failure)?;
                1
            }
            Inner::Level(level) => {
                let start = std::time::Instant::now();
                let within = std::time::Duration::from_secs_f64(budget_ms / 1e3);
                // The first system goes whatever the clock says: a frame always moves.
                let mut first = budget_ms > 0.0;
                let mut budget = || std::mem::take(&mut first) || start.elapsed() < within;
                let done = level
                    .systems_mut()
                    .update_within(&x, &mut budget)
                    .map_err(failure)?;
                y.copy_from_slice(level.gathered());
                done.len()
            }
            // On the GPU a frame updates every system.
            Inner::Gpu(level, ranges) => {
                level.frame(&x).map_err(gpu_failure)?;
                y.copy_from_slice(level.gathered());
                ranges.len()
            }
        };
        if !updated.is_null() {
            // SAFETY: non-NULL; the caller promises it is writable.
            unsafe { updated.write_unaligned(count) };
        }
        Ok(())
    })
}

/// How much system `s` of a level matters now, as a factor of its need in
/// rad_gather_update_within's choice (1 for every system at first; the camera near it: more,
/// far: less; 0 leaves it until nothing else needs an update). RAD_ERR_VALUE for `s` not below
/// rad_gather_systems or a negative or non-finite weight (the weight is kept). On a one-matrix
/// gather system 0 takes any valid weight and changes nothing; so does a GPU level's system
/// (its frame updates them all).
///
/// # Safety
///
/// `gather` is NULL or a live gather not in use by another thread.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_set_priority(
    gather: *mut RadGather,
    s: usize,
    weight: f32,
) -> i32 {
    status("rad_gather_set_priority", || {
        check_ptr(gather.cast_const(), "gather")?;
        // SAFETY: non-NULL and aligned (checked); the caller promises a live gather that no
        // other thread uses.
        let gather = unsafe { &mut *gather };
        let count = gather.systems();
        if s >= count {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("system {s}: the gather has {count} system(s)"),
            ));
        }
        if !(weight.is_finite() && weight >= 0.0) {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("a priority is a finite weight ≥ 0, not {weight}"),
            ));
        }
        if let Inner::Level(l) = &mut gather.inner {
            l.systems_mut().set_priority(s, weight);
        }
        Ok(())
    })
}

/// The patches of system `s`: `*start` and `*count` (the level's patches `start..start +
/// count`, in the numbering `x` and `y` use; the systems tile `0..n` in order). A one-matrix
/// gather is one system of every patch. RAD_ERR_VALUE for `s` not below rad_gather_systems.
///
/// # Safety
///
/// `gather` is NULL or a live gather; `start` and `count` are NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_gather_system_range(
    gather: *const RadGather,
    s: usize,
    start: *mut usize,
    count: *mut usize,
) -> i32 {
    status("rad_gather_system_range", || {
        check_ptr(gather, "gather")?;
        check_ptr(start.cast_const(), "start")?;
        check_ptr(count.cast_const(), "count")?;
        // SAFETY: non-NULL and aligned (checked); the caller promises a live gather.
        let gather = unsafe { &*gather };
        let range = match &gather.inner {
            Inner::One(g) if s == 0 => Some(0..g.patches()),
            Inner::One(_) => None,
            Inner::Level(l) => (s < l.count()).then(|| l.systems().range(s)),
            Inner::Gpu(_, ranges) => ranges.get(s).cloned(),
        };
        let Some(range) = range else {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("system {s}: the gather has {} system(s)", gather.systems()),
            ));
        };
        // SAFETY: non-NULL and aligned (checked); the caller promises both are writable.
        unsafe {
            start.write(range.start);
            count.write(range.len());
        }
        Ok(())
    })
}
