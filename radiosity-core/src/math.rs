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
    #[inline]
    pub(crate) fn sqrt(x: f32) -> f32 {
        x.sqrt()
    }
    #[inline]
    pub(crate) fn cos(x: f32) -> f32 {
        x.cos()
    }
    #[inline]
    pub(crate) fn sin(x: f32) -> f32 {
        x.sin()
    }
    #[inline]
    pub(crate) fn floor(x: f32) -> f32 {
        x.floor()
    }
    #[inline]
    pub(crate) fn acos(x: f32) -> f32 {
        x.acos()
    }
    #[inline]
    pub(crate) fn atan2(y: f32, x: f32) -> f32 {
        y.atan2(x)
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
    #[inline]
    pub(crate) fn sqrt(x: f32) -> f32 {
        libm::sqrtf(x)
    }
    #[inline]
    pub(crate) fn cos(x: f32) -> f32 {
        libm::cosf(x)
    }
    #[inline]
    pub(crate) fn sin(x: f32) -> f32 {
        libm::sinf(x)
    }
    #[inline]
    pub(crate) fn floor(x: f32) -> f32 {
        libm::floorf(x)
    }
    #[inline]
    pub(crate) fn acos(x: f32) -> f32 {
        libm::acosf(x)
    }
    #[inline]
    pub(crate) fn atan2(y: f32, x: f32) -> f32 {
        libm::atan2f(y, x)
    }
}

pub(crate) use imp::*;
