//! Reading plain-old-data out of section bytes: the helpers the `.rad` container and each
//! section's own `from_bytes` share. Nothing here knows the file layout; callers check every
//! length before they call.

use alloc::borrow::Cow;
use bytemuck::Pod;

/// Borrows `bytes` as `[T]` when aligned, copies otherwise. The caller has checked that the
/// length is a multiple of `size_of::<T>()`.
pub(crate) fn cast<T: Pod>(bytes: &[u8]) -> Cow<'_, [T]> {
    match bytemuck::try_cast_slice(bytes) {
        Ok(s) => Cow::Borrowed(s),
        Err(_) => {
            let mut v = alloc::vec![T::zeroed(); bytes.len() / core::mem::size_of::<T>()];
            bytemuck::cast_slice_mut::<T, u8>(&mut v).copy_from_slice(bytes);
            Cow::Owned(v)
        }
    }
}

/// The little-endian `u32` at byte `at`. The caller has checked that `bytes` holds
/// `at + 4` bytes.
pub(crate) fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cast_borrows_aligned_bytes_and_copies_unaligned_ones() {
        let words = [1u32, 2, 3];
        let bytes: &[u8] = bytemuck::cast_slice(&words);
        let aligned = cast::<u32>(bytes);
        assert!(matches!(aligned, Cow::Borrowed(_)));
        assert_eq!(&*aligned, &words);
        // One byte in: no longer 4-aligned, so the values are copied out.
        let mut shifted = alloc::vec![0u8; 13];
        shifted[1..].copy_from_slice(bytes);
        let copied = cast::<u32>(&shifted[1..]);
        assert!(matches!(copied, Cow::Owned(_)));
        assert_eq!(&*copied, &words);
    }

    #[test]
    fn u32_at_reads_little_endian() {
        assert_eq!(u32_at(&[0, 0x78, 0x56, 0x34, 0x12, 9], 1), 0x1234_5678);
    }
}
