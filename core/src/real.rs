//! The scalar type the whole core is generic over: f32 on the device, f64 on the host.

use num_traits::{Float, FloatConst, NumAssign};

/// A floating-point scalar usable everywhere in the core.
pub trait Real: Float + FloatConst + NumAssign + Default + core::fmt::Debug + 'static {
    /// Converts a literal or an f64 datum; constants are kept in f64 and narrowed once here.
    fn lit(x: f64) -> Self;
    /// Widens for reporting.
    fn to_f64(self) -> f64;
}

impl Real for f32 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x as f32
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self as f64
    }
}

impl Real for f64 {
    #[inline(always)]
    fn lit(x: f64) -> Self {
        x
    }
    #[inline(always)]
    fn to_f64(self) -> f64 {
        self
    }
}
