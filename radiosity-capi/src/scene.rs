//! `RadScene`: a parsed `.rad` file, its patches, object names and full-detail mesh, the
//! corner light and first exitance.

use crate::error::{Failure, check_ptr, guard, overlaps, slice, slice_mut, status};
use crate::{
    RAD_ERR_FORMAT, RAD_ERR_IO, RAD_ERR_LENGTH, RAD_ERR_NO_MESH, RAD_ERR_VALUE, RadPatch, RadRgb,
    RadTriangle,
};
use radiosity_core::{Mesh, MeshTriangle, RadFile, Rgb, first_exitance};
use std::borrow::Cow;
use std::ffi::{CStr, CString, c_char};
use std::path::PathBuf;

/// A parsed `.rad` file. Opaque: made by rad_scene_open or rad_scene_from_bytes, freed by
/// rad_scene_free.
pub struct RadScene {
    /// The file with its ray caster (the BVH over the full-detail mesh) and decoded probes.
    pub(crate) rt: radiosity_runtime::BakedScene,
    names: Vec<CString>,
}

impl RadScene {
    fn parse(bytes: &[u8]) -> Result<Self, Failure> {
        let file = RadFile::parse(bytes)
            .map_err(|e| Failure::new(RAD_ERR_FORMAT, format!("not a valid .rad file: {e}")))?
            .into_owned();
        // An object name with a NUL inside would be cut there by C: the NUL becomes a space.
        let names = file
            .objects
            .iter()
            .map(|n| CString::new(n.replace('\0', " ")).unwrap_or_default())
            .collect();
        Ok(Self {
            rt: radiosity_runtime::BakedScene::new(file),
            names,
        })
    }

    /// The mesh with at least one triangle, or the reason there is none.
    fn mesh(&self) -> Result<&Mesh<'static>, Failure> {
        match &self.rt.file.mesh {
            Some(m) if !m.triangles.is_empty() => Ok(m),
            Some(_) => Err(Failure::new(
                RAD_ERR_NO_MESH,
                "the scene's full-detail mesh has no triangles",
            )),
            None => Err(Failure::new(
                RAD_ERR_NO_MESH,
                "the scene has no full-detail mesh (the bake did not store one)",
            )),
        }
    }

    fn triangles(&self) -> &[MeshTriangle] {
        self.rt.file.mesh.as_ref().map_or(&[], |m| &m.triangles)
    }
}

/// The scene behind `scene`, the argument of every scene function.
///
/// # Safety
///
/// A non-NULL `scene` comes from rad_scene_open or rad_scene_from_bytes and is not freed.
pub(crate) unsafe fn scene_ref<'a>(scene: *const RadScene) -> Result<&'a RadScene, Failure> {
    check_ptr(scene, "scene")?;
    // SAFETY: non-NULL and aligned (checked); the caller promises a live scene, which no
    // function mutates after it is made.
    Ok(unsafe { &*scene })
}

fn out_ptr(out: *mut *mut RadScene) -> Result<(), Failure> {
    check_ptr(out.cast_const(), "out")
}

fn give(out: *mut *mut RadScene, scene: RadScene) {
    // SAFETY: `out` was checked non-NULL and aligned by `out_ptr`; the caller promises it is
    // writable.
    unsafe { out.write(Box::into_raw(Box::new(scene))) };
}

fn clear(out: *mut *mut RadScene) {
    if check_ptr(out.cast_const(), "out").is_ok() {
        // SAFETY: as in `give`.
        unsafe { out.write(std::ptr::null_mut()) };
    }
}

#[cfg(unix)]
fn to_path(path: &CStr) -> Result<PathBuf, Failure> {
    use std::os::unix::ffi::OsStrExt;
    Ok(PathBuf::from(std::ffi::OsStr::from_bytes(path.to_bytes())))
}

#[cfg(not(unix))]
fn to_path(path: &CStr) -> Result<PathBuf, Failure> {
    path.to_str()
        .map(PathBuf::from)
        .map_err(|_| Failure::new(RAD_ERR_VALUE, "path is not UTF-8"))
}

/// Opens and fully validates the `.rad` file at `path` (a NUL-terminated path in the
/// platform's encoding). On success writes a new scene to `*out` and returns 0; on failure
/// writes NULL to `*out` (when `out` is not NULL) and returns RAD_ERR_POINTER, RAD_ERR_IO or
/// RAD_ERR_FORMAT.
///
/// # Safety
///
/// `path` is NULL or a NUL-terminated string; `out` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_open(path: *const c_char, out: *mut *mut RadScene) -> i32 {
    status("rad_scene_open", || {
        out_ptr(out)?;
        clear(out);
        check_ptr(path, "path")?;
        // SAFETY: non-NULL (checked); the caller promises a NUL-terminated string.
        let path = to_path(unsafe { CStr::from_ptr(path) })?;
        let bytes = std::fs::read(&path).map_err(|e| {
            Failure::new(RAD_ERR_IO, format!("cannot read {}: {e}", path.display()))
        })?;
        let scene = RadScene::parse(&bytes)
            .map_err(|f| Failure::new(f.code, format!("{}: {}", path.display(), f.message)))?;
        give(out, scene);
        Ok(())
    })
}

/// Parses and fully validates a `.rad` file held in memory: `len` bytes at `bytes`, which are
/// copied (the caller may free them on return). Writes the scene to `*out` as rad_scene_open.
///
/// # Safety
///
/// `bytes` is NULL or points to `len` readable bytes; `out` is NULL or writable.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_from_bytes(
    bytes: *const u8,
    len: usize,
    out: *mut *mut RadScene,
) -> i32 {
    status("rad_scene_from_bytes", || {
        out_ptr(out)?;
        clear(out);
        // SAFETY: the caller promises `len` readable bytes at a non-NULL `bytes`.
        let bytes = unsafe { slice(bytes, len, "bytes") }?;
        give(out, RadScene::parse(bytes)?);
        Ok(())
    })
}

/// Frees a scene. NULL is a no-op. Free the scene's gathers first.
///
/// # Safety
///
/// `scene` is NULL or a scene not yet freed; no pointer it returned is used afterwards.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_free(scene: *mut RadScene) {
    guard("rad_scene_free", (), || {
        if !scene.is_null() {
            // SAFETY: the caller promises a scene from Box::into_raw (rad_scene_open or
            // rad_scene_from_bytes), freed once.
            drop(unsafe { Box::from_raw(scene) });
        }
        Ok(())
    })
}

/// Patches of the scene: the length of every per-patch array (`n`). 0 for a NULL scene.
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_patch_count(scene: *const RadScene) -> usize {
    // SAFETY: the caller promises a live scene or NULL (checked).
    guard("rad_scene_patch_count", 0, || {
        Ok(unsafe { scene_ref(scene) }?.rt.file.n())
    })
}

/// The scene's patches, rad_scene_patch_count of them in the matrix numbering, owned by the
/// scene. NULL for a NULL scene.
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_patches(scene: *const RadScene) -> *const RadPatch {
    guard("rad_scene_patches", std::ptr::null(), || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        let patches: &[RadPatch] = bytemuck::cast_slice(&scene.rt.file.patches);
        Ok(patches.as_ptr())
    })
}

/// Objects of the scene (the OBJ's objects; RadPatch::object indexes them). 0 for NULL.
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_object_count(scene: *const RadScene) -> usize {
    // SAFETY: the caller promises a live scene or NULL (checked).
    guard("rad_scene_object_count", 0, || {
        Ok(unsafe { scene_ref(scene) }?.names.len())
    })
}

/// The name of object `index`, a NUL-terminated UTF-8 string owned by the scene; NULL past the
/// end or for a NULL scene.
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_object_name(
    scene: *const RadScene,
    index: usize,
) -> *const c_char {
    guard("rad_scene_object_name", std::ptr::null(), || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        let name = scene.names.get(index).ok_or_else(|| {
            Failure::new(
                RAD_ERR_LENGTH,
                format!(
                    "object {index} past the end ({} objects)",
                    scene.names.len()
                ),
            )
        })?;
        Ok(name.as_ptr())
    })
}

/// Triangles of the full-detail mesh; 0 when the file has none (or for a NULL scene).
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_triangle_count(scene: *const RadScene) -> usize {
    guard("rad_scene_triangle_count", 0, || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        Ok(unsafe { scene_ref(scene) }?.triangles().len())
    })
}

/// The full-detail mesh's triangles, rad_scene_triangle_count of them, owned by the scene;
/// NULL when there is no mesh (or for a NULL scene).
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_triangles(scene: *const RadScene) -> *const RadTriangle {
    guard("rad_scene_triangles", std::ptr::null(), || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let mesh = unsafe { scene_ref(scene) }?.mesh()?;
        let triangles: &[RadTriangle] = bytemuck::cast_slice(&mesh.triangles);
        Ok(triangles.as_ptr())
    })
}

/// Vertices of the full-detail mesh; 0 when the file has none (or for a NULL scene).
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_vertex_count(scene: *const RadScene) -> usize {
    guard("rad_scene_vertex_count", 0, || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        Ok(scene.rt.file.mesh.as_ref().map_or(0, |m| m.positions.len()))
    })
}

/// The full-detail mesh's vertex positions, 3 floats (x, y, z) per vertex, owned by the scene;
/// NULL when there is no mesh (or for a NULL scene).
///
/// # Safety
///
/// `scene` is NULL or a live scene.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_vertices(scene: *const RadScene) -> *const f32 {
    guard("rad_scene_vertices", std::ptr::null(), || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let mesh = unsafe { scene_ref(scene) }?.mesh()?;
        let floats: &[f32] = bytemuck::cast_slice(&mesh.positions);
        Ok(floats.as_ptr())
    })
}

pub(crate) fn check_n(scene: &RadScene, n: usize, what: &str) -> Result<(), Failure> {
    if n != scene.rt.file.n() {
        return Err(Failure::new(
            RAD_ERR_LENGTH,
            format!(
                "{what}: n = {n}, the scene has {} patches",
                scene.rt.file.n()
            ),
        ));
    }
    Ok(())
}

/// Reads `n` values at `input` for a call that writes `out_len` values at `output`: borrowed
/// when the two are apart, copied when they overlap (so the caller may pass the same array).
///
/// # Safety
///
/// `input` is NULL or points to `n` readable values that nothing writes while the result lives
/// (other than through `output`, which the copy covers).
pub(crate) unsafe fn read_input<'a>(
    input: *const RadRgb,
    n: usize,
    output: *const RadRgb,
    out_len: usize,
    what: &str,
) -> Result<Cow<'a, [Rgb]>, Failure> {
    // SAFETY: the caller promises `n` readable values at a non-NULL `input`.
    let values: &'a [RadRgb] = unsafe { slice(input, n, what) }?;
    let values: &'a [Rgb] = bytemuck::cast_slice(values);
    if overlaps(input, n, output, out_len) {
        Ok(Cow::Owned(values.to_vec()))
    } else {
        Ok(Cow::Borrowed(values))
    }
}

/// Indirect irradiance (W/m²) at every corner of the full-detail mesh from the gather's
/// per-patch irradiance `y` (`n` = patch count): `corners` = 3 × triangle count values written
/// to `out`, triangle-major, corner c of triangle t at `out[3t + c]` (the corner at vertex
/// `RadTriangle::vertices[c]`). Each corner sums its stored weights times `y`, in f32, in the
/// order the file stores them (the core's `Mesh::corner_indirect`). Multiply by the surface's
/// reflectance for the indirect radiosity to draw. RAD_ERR_NO_MESH when the file has no mesh.
///
/// # Safety
///
/// `scene` is NULL or a live scene; `y` is NULL or `n` readable values; `out` is NULL or
/// `corners` writable values (it may overlap `y`).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_scene_corner_indirect(
    scene: *const RadScene,
    y: *const RadRgb,
    n: usize,
    out: *mut RadRgb,
    corners: usize,
) -> i32 {
    status("rad_scene_corner_indirect", || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        let mesh = scene.mesh()?;
        check_n(scene, n, "y")?;
        if corners != mesh.corner_count() {
            return Err(Failure::new(
                RAD_ERR_LENGTH,
                format!(
                    "corners = {corners}, the mesh has {} (3 per triangle)",
                    mesh.corner_count()
                ),
            ));
        }
        // SAFETY: the caller promises `n` readable values at `y`; any overlap with `out` is
        // copied away before `out` is borrowed.
        let y = unsafe { read_input(y, n, out.cast_const(), corners, "y") }?;
        // SAFETY: the caller promises `corners` writable values at a non-NULL `out`; `y` no
        // longer borrows them if they overlapped.
        let out = unsafe { slice_mut(out, corners, "out") }?;
        mesh.corner_indirect(&y, bytemuck::cast_slice_mut(out))
            .map_err(|e| Failure::new(RAD_ERR_LENGTH, e.to_string()))
    })
}

/// First exitance `x = E + ρ · direct` per patch (the core's `first_exitance`) from the host's
/// direct irradiance `direct` (W/m², `n` = patch count; all zeros for the scene's own emitters
/// alone). `direct` and `x` may be the same array. RAD_ERR_VALUE for a negative or non-finite
/// `direct`.
///
/// # Safety
///
/// `scene` is NULL or a live scene; `direct` is NULL or `n` readable values; `x` is NULL or
/// `n` writable values.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_first_exitance(
    scene: *const RadScene,
    direct: *const RadRgb,
    x: *mut RadRgb,
    n: usize,
) -> i32 {
    status("rad_first_exitance", || {
        // SAFETY: the caller promises a live scene or NULL (checked).
        let scene = unsafe { scene_ref(scene) }?;
        check_n(scene, n, "direct")?;
        // SAFETY: the caller promises `n` readable values at `direct`; an overlap with `x` is
        // copied away.
        let direct = unsafe { read_input(direct, n, x.cast_const(), n, "direct") }?;
        if let Some(i) = direct
            .iter()
            .position(|d| !(d.is_finite() && d.to_array().iter().all(|c| *c >= 0.0)))
        {
            return Err(Failure::new(
                RAD_ERR_VALUE,
                format!("direct irradiance of patch {i} is negative or not finite"),
            ));
        }
        // SAFETY: the caller promises `n` writable values at a non-NULL `x`; `direct` no
        // longer borrows them if they overlapped.
        let x = unsafe { slice_mut(x, n, "x") }?;
        first_exitance(&scene.rt.file.patches, &direct, bytemuck::cast_slice_mut(x));
        Ok(())
    })
}
