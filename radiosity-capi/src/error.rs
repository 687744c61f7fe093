//! This thread's last failure, the guard every exported function runs its body in (errors and
//! caught panics become a status code and a message), and the pointer checks.

use crate::{RAD_ERR_LENGTH, RAD_ERR_PANIC, RAD_ERR_POINTER, RAD_OK};
use std::any::Any;
use std::cell::RefCell;
use std::ffi::{CString, c_char};
use std::mem::{align_of, size_of};
use std::panic::{AssertUnwindSafe, catch_unwind};

thread_local! {
    static LAST_ERROR: RefCell<CString> = RefCell::new(CString::default());
}

/// A failed call: the status code it returns and the message rad_last_error gives.
#[derive(Debug)]
pub(crate) struct Failure {
    pub(crate) code: i32,
    pub(crate) message: String,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.message)
    }
}

impl Failure {
    pub(crate) fn new(code: i32, message: impl Into<String>) -> Self {
        Self {
            code,
            message: message.into(),
        }
    }
}

fn set_last_error(message: String) {
    // A message with a NUL inside would be cut there by C; replace it instead.
    let message = CString::new(message.replace('\0', " ")).unwrap_or_default();
    LAST_ERROR.with(|e| *e.borrow_mut() = message);
}

fn panic_message(payload: &(dyn Any + Send)) -> &str {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s
    } else {
        "a panic without a message"
    }
}

/// Runs `body` for the exported function `name`: its value on success; on a failure or a
/// caught panic, `fail`, with this thread's last error set to `name: message`.
pub(crate) fn guard<T>(name: &str, fail: T, body: impl FnOnce() -> Result<T, Failure>) -> T {
    match catch_unwind(AssertUnwindSafe(body)) {
        Ok(Ok(v)) => v,
        Ok(Err(f)) => {
            set_last_error(format!("{name}: {}", f.message));
            fail
        }
        Err(payload) => {
            set_last_error(format!(
                "{name}: internal error (caught panic: {})",
                panic_message(payload.as_ref())
            ));
            fail
        }
    }
}

/// guard for a function that returns a status code: RAD_OK or the failure's code
/// (RAD_ERR_PANIC for a caught panic).
pub(crate) fn status(name: &str, body: impl FnOnce() -> Result<(), Failure>) -> i32 {
    let mut code = RAD_ERR_PANIC;
    guard(name, (), || match body() {
        Ok(()) => {
            code = RAD_OK;
            Ok(())
        }
        Err(f) => {
            code = f.code;
            Err(f)
        }
    });
    code
}

/// Checks that `p`, the argument `what`, is non-NULL and aligned for `T`.
pub(crate) fn check_ptr<T>(p: *const T, what: &str) -> Result<(), Failure> {
    if p.is_null() {
        return Err(Failure::new(RAD_ERR_POINTER, format!("{what} is NULL")));
    }
    if !(p as usize).is_multiple_of(align_of::<T>()) {
        return Err(Failure::new(
            RAD_ERR_POINTER,
            format!("{what} is not aligned to {} bytes", align_of::<T>()),
        ));
    }
    Ok(())
}

fn check_array<T>(p: *const T, len: usize, what: &str) -> Result<(), Failure> {
    check_ptr(p, what)?;
    if len
        .checked_mul(size_of::<T>())
        .is_none_or(|bytes| bytes > isize::MAX as usize)
    {
        return Err(Failure::new(
            RAD_ERR_LENGTH,
            format!("{what}: {len} elements is too long"),
        ));
    }
    Ok(())
}

/// The `len` elements at `p` (the argument `what`), after the NULL, alignment and size checks.
///
/// # Safety
///
/// A non-NULL `p` points to `len` initialised elements that nothing writes while the slice
/// lives (the caller's promise, passed on from the C caller).
pub(crate) unsafe fn slice<'a, T>(p: *const T, len: usize, what: &str) -> Result<&'a [T], Failure> {
    check_array(p, len, what)?;
    // SAFETY: `p` is non-NULL, aligned and `len` elements fit in isize (checked above); the
    // caller promises they are initialised and not written meanwhile.
    Ok(unsafe { std::slice::from_raw_parts(p, len) })
}

/// The `len` elements at `p` for writing, after the same checks as slice.
///
/// # Safety
///
/// A non-NULL `p` points to `len` writable elements that nothing else reads or writes while
/// the slice lives.
pub(crate) unsafe fn slice_mut<'a, T>(
    p: *mut T,
    len: usize,
    what: &str,
) -> Result<&'a mut [T], Failure> {
    check_array(p.cast_const(), len, what)?;
    // SAFETY: `p` is non-NULL, aligned and `len` elements fit in isize (checked above); the
    // caller promises the memory is writable and not otherwise accessed meanwhile.
    Ok(unsafe { std::slice::from_raw_parts_mut(p, len) })
}

/// Whether `a_len` elements at `a` and `b_len` at `b` share any byte.
pub(crate) fn overlaps<T>(a: *const T, a_len: usize, b: *const T, b_len: usize) -> bool {
    let bytes = |len: usize| len.saturating_mul(size_of::<T>());
    let (a, b) = (a as usize, b as usize);
    a < b.saturating_add(bytes(b_len)) && b < a.saturating_add(bytes(a_len))
}

/// This thread's last failure: a NUL-terminated message naming the function and the reason,
/// or "" when nothing has failed on this thread. Owned by the library and valid until this
/// thread's next call into it; never NULL.
#[unsafe(no_mangle)]
pub extern "C" fn rad_last_error() -> *const c_char {
    // The string lives in this thread's slot until the next failure replaces it.
    LAST_ERROR.with(|e| e.borrow().as_ptr())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ffi::CStr;

    fn last() -> String {
        // SAFETY: rad_last_error never returns NULL and its string lives until the next call.
        unsafe { CStr::from_ptr(rad_last_error()) }
            .to_str()
            .unwrap()
            .to_owned()
    }

    #[test]
    fn failures_and_panics_become_codes_and_messages() {
        assert_eq!(status("f", || Ok(())), RAD_OK);
        assert_eq!(
            status("f", || Err(Failure::new(RAD_ERR_LENGTH, "too short"))),
            RAD_ERR_LENGTH
        );
        assert_eq!(last(), "f: too short");
        assert_eq!(status("g", || panic!("boom")), RAD_ERR_PANIC);
        assert!(last().starts_with("g: internal error"), "{}", last());
        assert!(last().contains("boom"));
        let v = guard("h", 7usize, || Err(Failure::new(RAD_ERR_POINTER, "a\0b")));
        assert_eq!(v, 7);
        assert_eq!(last(), "h: a b");
    }

    #[test]
    fn the_last_error_is_per_thread() {
        status("main", || Err(Failure::new(RAD_ERR_LENGTH, "here")));
        std::thread::spawn(|| assert_eq!(last(), ""))
            .join()
            .unwrap();
        assert_eq!(last(), "main: here");
    }

    #[test]
    fn pointers_are_checked() {
        let v = [1u32, 2, 3];
        assert!(check_ptr(v.as_ptr(), "v").is_ok());
        assert_eq!(
            check_ptr(std::ptr::null::<u32>(), "v").unwrap_err().code,
            RAD_ERR_POINTER
        );
        let odd = (v.as_ptr() as usize + 1) as *const u32;
        assert_eq!(check_ptr(odd, "v").unwrap_err().code, RAD_ERR_POINTER);
        assert_eq!(
            check_array(v.as_ptr(), usize::MAX / 2, "v")
                .unwrap_err()
                .code,
            RAD_ERR_LENGTH
        );
        assert!(overlaps(v.as_ptr(), 2, v[1..].as_ptr(), 1));
        assert!(!overlaps(v.as_ptr(), 1, v[1..].as_ptr(), 2));
        assert!(overlaps(v[2..].as_ptr(), 1, v.as_ptr(), 3));
        assert!(!overlaps(v[2..].as_ptr(), 1, v.as_ptr(), 2));
    }
}
