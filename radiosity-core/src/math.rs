//! The one place float maths is chosen: the platform's with `std`, `libm` without.
//! (glam does the same in `src/f32/math.rs`.)

#[cfg(feature = "std")]
mod imp {
    #[inline]
    pub(crate) fn ln(x: f32) -> f32 {
        x.ln()
    }
    #[inline]
    pub(crate) fn exp(x: f32) -> f32 {
        x.exp()
    }
    #[inline]
    pub(crate) fn round(x: f32) -> f32 {
        x.round()
    }
}

#[cfg(not(feature = "std"))]
mod imp {
    #[inline]
    pub(crate) fn ln(x: f32) -> f32 {
        libm::logf(x)
    }
    #[inline]
    pub(crate) fn exp(x: f32) -> f32 {
        libm::expf(x)
    }
    #[inline]
    pub(crate) fn round(x: f32) -> f32 {
        libm::roundf(x)
    }
}

pub(crate) use imp::*;
