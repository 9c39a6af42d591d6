//! A small floating-point trait so the kernels run in `f32` for speed and in `f64` for gradient tests.

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, MulAssign, Neg, Sub, SubAssign};

/// The scalar type of every kernel: implemented for `f32` (training, rendering) and `f64` (finite-difference
/// tests). Only what the kernels need is here.
pub trait Real:
    Copy
    + Send
    + Sync
    + Default
    + PartialOrd
    + Debug
    + 'static
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
    + AddAssign
    + SubAssign
    + MulAssign
{
    /// 0.
    const ZERO: Self;
    /// 1.
    const ONE: Self;
    /// Conversion from `f64` (rounding for `f32`).
    fn from_f64(x: f64) -> Self;
    /// Conversion to `f64`.
    fn to_f64(self) -> f64;
    /// Exponential.
    fn exp(self) -> Self;
    /// Natural logarithm.
    fn ln(self) -> Self;
    /// Square root.
    fn sqrt(self) -> Self;
    /// Largest integer not above.
    fn floor(self) -> Self;
    /// Larger of two (NaN-free inputs).
    fn max(self, other: Self) -> Self {
        if self > other { self } else { other }
    }
    /// Smaller of two (NaN-free inputs).
    fn min(self, other: Self) -> Self {
        if self < other { self } else { other }
    }
    /// Conversion from `usize` (exact for the small integers used as grid coordinates).
    fn from_usize(x: usize) -> Self {
        Self::from_f64(x as f64)
    }
    /// Truncation to a non-negative grid coordinate, without a detour through `f64`.
    fn to_u32(self) -> u32;
    /// Conversion from a grid coordinate (exact below 2^24).
    fn from_u32(x: u32) -> Self;
    /// The slice as `f32`, when `Self` is `f32` (lets kernels take an `f32`-only fast path safely).
    fn as_f32(s: &[Self]) -> Option<&[f32]>;
    /// Logistic sigmoid `1 / (1 + e^-x)`.
    fn sigmoid(self) -> Self {
        Self::ONE / (Self::ONE + (-self).exp())
    }
}

macro_rules! impl_real {
    ($t:ty, $as_f32:expr) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            #[inline(always)]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn as_f32(s: &[Self]) -> Option<&[f32]> {
                $as_f32(s)
            }
            #[inline(always)]
            fn to_u32(self) -> u32 {
                self as u32
            }
            #[inline(always)]
            fn from_u32(x: u32) -> Self {
                x as $t
            }
            #[inline(always)]
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                <$t>::ln(self)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn floor(self) -> Self {
                <$t>::floor(self)
            }
        }
    };
}

impl_real!(f32, Some);
impl_real!(f64, |_| None);
