//! The bake through C ([`rad_bake`]): `radiosity_bake::host::bake_file` with the host's
//! progress callback and cancellation.

use crate::error::{Failure, status};
use crate::{RAD_ERR_CANCELLED, RAD_ERR_IO, RAD_ERR_VALUE};
use radiosity_bake::BakeError;
use radiosity_bake::host::{BakeFlags, bake_file};
use radiosity_bake::scene::SceneError;
use std::ffi::{CStr, CString, c_char, c_void};
use std::path::PathBuf;

/// Called during a bake with the stage's name (a NUL-terminated string valid during the call)
/// and the fraction of the bake done, in [0, 1], never decreasing, 1 at the end. Called on the
/// thread that called rad_bake, about every 100 ms. A non-zero return cancels the bake:
/// rad_bake then returns RAD_ERR_CANCELLED and leaves nothing at the output path.
pub type RadProgress =
    Option<unsafe extern "C" fn(user: *mut c_void, stage: *const c_char, fraction: f64) -> i32>;

/// A NUL-terminated UTF-8 path argument.
///
/// # Safety
///
/// A non-NULL `p` points to a NUL-terminated string.
unsafe fn path_arg(p: *const c_char, what: &str) -> Result<PathBuf, Failure> {
    crate::error::check_ptr(p, what)?;
    // SAFETY: non-NULL (checked); the caller promises a NUL-terminated string.
    let s = unsafe { CStr::from_ptr(p) }
        .to_str()
        .map_err(|_| Failure::new(RAD_ERR_VALUE, format!("{what} is not UTF-8")))?;
    Ok(PathBuf::from(s))
}

/// The C status of a bake error.
fn bake_failure(e: BakeError) -> Failure {
    let code = match &e {
        BakeError::Cancelled => RAD_ERR_CANCELLED,
        BakeError::Scene(SceneError::Io { .. }) => RAD_ERR_IO,
        _ => RAD_ERR_VALUE,
    };
    Failure::new(code, e.to_string())
}

/// Bakes an OBJ or glTF scene into `output_path` (written atomically: a failed or cancelled bake
/// leaves nothing there). `options_json`: the bake flags as a JSON object, long names with '_'
/// for '-' ({"patches": 1024, "format": "bc1", "probes": "none"}); NULL or "{}" for the
/// defaults (those of `radiosity bake`); an unknown key is an error. `progress` may be NULL;
/// `user` is passed to it. RAD_ERR_VALUE for bad options or a scene that cannot be loaded or
/// baked (the message says which), RAD_ERR_IO for a file that cannot be read,
/// RAD_ERR_CANCELLED when `progress` asked to stop.
///
/// # Safety
///
/// `scene_path` and `output_path` are NULL or NUL-terminated strings; `options_json` is NULL or
/// a NUL-terminated string; `progress`, if not NULL, is safe to call with `user`.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn rad_bake(
    scene_path: *const c_char,
    output_path: *const c_char,
    options_json: *const c_char,
    progress: RadProgress,
    user: *mut c_void,
) -> i32 {
    status("rad_bake", || {
        // SAFETY: the caller promises NUL-terminated strings or NULL (checked).
        let scene = unsafe { path_arg(scene_path, "scene_path") }?;
        // SAFETY: as above.
        let output = unsafe { path_arg(output_path, "output_path") }?;
        let flags = if options_json.is_null() {
            BakeFlags::default()
        } else {
            // SAFETY: non-NULL; the caller promises a NUL-terminated string.
            let text = unsafe { CStr::from_ptr(options_json) }
                .to_str()
                .map_err(|_| Failure::new(RAD_ERR_VALUE, "options_json is not UTF-8"))?;
            BakeFlags::from_json(text).map_err(bake_failure)?
        };
        let mut call = |stage: &str, fraction: f64| -> bool {
            let Some(f) = progress else {
                return true;
            };
            let name = CString::new(stage).unwrap_or_default();
            // SAFETY: the caller promises `progress` is safe to call with `user`; `name` lives
            // through the call.
            unsafe { f(user, name.as_ptr(), fraction) == 0 }
        };
        bake_file(&scene, &output, &flags, &mut call)
            .map(drop)
            .map_err(bake_failure)
    })
}
