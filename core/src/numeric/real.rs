//! The scalar type the whole core is generic over (f32 on the device, f64 on the host), and the
//! one place that defines the core's math on it and on [`C`].
//!
//! Every transcendental function goes through the `libm` crate explicitly, but f32's sine and
//! cosine, which are the core's own ([`super::sine_f32`]: f32 arithmetic only, where libm's
//! reduce any argument and evaluate in f64, which the device does in software). `num_traits::Float`
//! would pick its implementation from Cargo features: with `num-traits/std` enabled anywhere in
//! the same build (plotters does it), f32 `sin`/`exp`/`atan2`… come from the host's C library
//! instead of `libm`, the f32 design coefficients change in their last bits on the host, and the
//! host no longer reproduces the firmware bit for bit. So [`Real`] does not extend `Float`, the
//! core depends on num-traits and num-complex without their `libm`/`std` features (they bring no
//! float functions at all), and the complex functions num-complex defines through `Float`
//! (`norm`, `arg`, `exp`, `sqrt`) are provided here as [`ComplexMath`] (`cabs`, `carg`, `cexp`,
//! `csqrt`). Code that reaches for `Float` does not compile. The tool depends on num-traits with
//! `std` on purpose, so the host ↔ QEMU equivalence test (`cargo xtask test`) guards this.

use core::fmt::Debug;
use core::ops::Neg;
use num_traits::{FloatConst, Num, NumAssign};

use super::sine_f32;

/// Complex numbers over the crate's real type.
pub type C<T> = num_complex::Complex<T>;

/// A floating-point scalar usable everywhere in the core.
pub trait Real: Num + NumAssign + Copy + PartialOrd + Neg<Output = Self> + FloatConst + Default + Debug + 'static {
    /// Converts a literal or an f64 datum; constants are kept in f64 and narrowed once here.
    fn lit(x: f64) -> Self;
    /// A table's 16-bit code, converted in the type itself (no detour through f64, which the
    /// device does in software).
    fn from_u16(x: u16) -> Self;
    /// The integer's value (to the nearest the type holds; one instruction on the device).
    fn from_i32(x: i32) -> Self;
    /// Toward zero, saturating at the type's ends (NaN: 0), as `as u32` has it.
    fn to_u32(self) -> u32;
    /// Widens for reporting.
    fn to_f64(self) -> f64;

    fn epsilon() -> Self;
    fn infinity() -> Self;
    fn nan() -> Self;
    fn is_finite(self) -> bool;
    fn is_nan(self) -> bool;
    fn is_sign_negative(self) -> bool;
    fn abs(self) -> Self;
    fn max(self, other: Self) -> Self;
    fn min(self, other: Self) -> Self;
    fn floor(self) -> Self;
    fn ceil(self) -> Self;
    fn round(self) -> Self;
    fn recip(self) -> Self;
    fn to_degrees(self) -> Self;

    fn sqrt(self) -> Self;
    fn exp(self) -> Self;
    fn ln(self) -> Self;
    fn powf(self, e: Self) -> Self;
    fn sin(self) -> Self;
    fn cos(self) -> Self;
    /// (sin, cos) in one call: one argument reduction for both.
    fn sin_cos(self) -> (Self, Self);
    fn sinh(self) -> Self;
    fn cosh(self) -> Self;
    fn atan2(self, x: Self) -> Self;
    fn hypot(self, other: Self) -> Self;
}

/// `$t` with its `libm` functions (`$sqrt` …: the f32 or the f64 names), and its sine and cosine
/// (`$sin` …: paths).
macro_rules! real_via_libm {
    ($t:ty, $sqrt:ident, $exp:ident, $ln:ident, $pow:ident, $sin:path, $cos:path, $sin_cos:path, $sinh:ident, $cosh:ident, $atan2:ident, $hypot:ident, $floor:ident, $ceil:ident, $round:ident) => {
        impl Real for $t {
            #[inline(always)]
            fn lit(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn from_u16(x: u16) -> Self {
                x as $t
            }
            #[inline(always)]
            fn from_i32(x: i32) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_u32(self) -> u32 {
                self as u32
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline(always)]
            fn epsilon() -> Self {
                <$t>::EPSILON
            }
            #[inline(always)]
            fn infinity() -> Self {
                <$t>::INFINITY
            }
            #[inline(always)]
            fn nan() -> Self {
                <$t>::NAN
            }
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn is_nan(self) -> bool {
                <$t>::is_nan(self)
            }
            #[inline(always)]
            fn is_sign_negative(self) -> bool {
                <$t>::is_sign_negative(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn max(self, other: Self) -> Self {
                <$t>::max(self, other)
            }
            #[inline(always)]
            fn min(self, other: Self) -> Self {
                <$t>::min(self, other)
            }
            #[inline(always)]
            fn recip(self) -> Self {
                <$t>::recip(self)
            }
            #[inline(always)]
            fn to_degrees(self) -> Self {
                <$t>::to_degrees(self)
            }
            #[inline(always)]
            fn floor(self) -> Self {
                libm::$floor(self)
            }
            #[inline(always)]
            fn ceil(self) -> Self {
                libm::$ceil(self)
            }
            #[inline(always)]
            fn round(self) -> Self {
                libm::$round(self)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                libm::$sqrt(self)
            }
            #[inline(always)]
            fn exp(self) -> Self {
                libm::$exp(self)
            }
            #[inline(always)]
            fn ln(self) -> Self {
                libm::$ln(self)
            }
            #[inline(always)]
            fn powf(self, e: Self) -> Self {
                libm::$pow(self, e)
            }
            #[inline(always)]
            fn sin(self) -> Self {
                $sin(self)
            }
            #[inline(always)]
            fn cos(self) -> Self {
                $cos(self)
            }
            #[inline(always)]
            fn sin_cos(self) -> (Self, Self) {
                $sin_cos(self)
            }
            #[inline(always)]
            fn sinh(self) -> Self {
                libm::$sinh(self)
            }
            #[inline(always)]
            fn cosh(self) -> Self {
                libm::$cosh(self)
            }
            #[inline(always)]
            fn atan2(self, x: Self) -> Self {
                libm::$atan2(self, x)
            }
            #[inline(always)]
            fn hypot(self, other: Self) -> Self {
                libm::$hypot(self, other)
            }
        }
    };
}

real_via_libm!(
    f32,
    sqrtf,
    expf,
    logf,
    powf,
    sine_f32::sin,
    sine_f32::cos,
    sine_f32::sin_cos,
    sinhf,
    coshf,
    atan2f,
    hypotf,
    floorf,
    ceilf,
    roundf
);
real_via_libm!(f64, sqrt, exp, log, pow, libm::sin, libm::cos, libm::sincos, sinh, cosh, atan2, hypot, floor, ceil, round);

/// e^(iθ) = cos θ + i sin θ.
#[inline]
pub fn cis<T: Real>(theta: T) -> C<T> {
    let (sin, cos) = theta.sin_cos();
    C::new(cos, sin)
}

/// The complex functions the core uses, on [`Real`], named as in C99's `<complex.h>`. num-complex's
/// own (`norm`, `arg`, `exp`, `sqrt`) go through `Float`; the formulas here are theirs, so results
/// match them wherever their `Float` is `libm`.
pub trait ComplexMath<T>: Sized {
    /// |z|
    fn cabs(self) -> T;
    /// The principal argument, in (−π, π].
    fn carg(self) -> T;
    fn cexp(self) -> Self;
    /// The principal square root (Re ≥ 0).
    fn csqrt(self) -> Self;
    /// (cos, sin, cosh, sinh) of one argument: each part's sine, cosine and hyperbolic functions
    /// evaluated once for all four.
    fn ccos_csin_ccosh_csinh(self) -> [Self; 4];
}

impl<T: Real> ComplexMath<T> for C<T> {
    #[inline]
    fn cabs(self) -> T {
        self.re.hypot(self.im)
    }
    #[inline]
    fn carg(self) -> T {
        self.im.atan2(self.re)
    }
    #[inline]
    fn cexp(self) -> Self {
        // e^(a+ib) = e^a·(cos b + i sin b)
        let r = self.re.exp();
        let (sin, cos) = self.im.sin_cos();
        C::new(r * cos, r * sin)
    }
    fn csqrt(self) -> Self {
        let half = T::lit(0.5);
        if self.im == T::zero() {
            if !self.re.is_sign_negative() {
                return C::new(self.re.sqrt(), self.im);
            }
            // √(−r) = ±i√r, on the side of the zero imaginary part's sign
            let root = (-self.re).sqrt();
            return C::new(T::zero(), if self.im.is_sign_negative() { -root } else { root });
        }
        if self.re == T::zero() {
            // √(±ib) = √(b/2)·(1 ± i)
            let x = (self.im.abs() * half).sqrt();
            return C::new(x, if self.im.is_sign_negative() { -x } else { x });
        }
        // √(r·e^(iθ)) = √r·e^(iθ/2)
        let (r, half_theta) = (self.cabs().sqrt(), self.carg() * half);
        let (sin, cos) = half_theta.sin_cos();
        C::new(r * cos, r * sin)
    }
    fn ccos_csin_ccosh_csinh(self) -> [Self; 4] {
        let (a, b) = (self.re, self.im);
        let ((sin_a, cos_a), (sin_b, cos_b)) = (a.sin_cos(), b.sin_cos());
        let (cosh_a, sinh_a, cosh_b, sinh_b) = (a.cosh(), a.sinh(), b.cosh(), b.sinh());
        [
            // cos(a+ib) = cos a·cosh b − i·sin a·sinh b
            C::new(cos_a * cosh_b, -sin_a * sinh_b),
            // sin(a+ib) = sin a·cosh b + i·cos a·sinh b
            C::new(sin_a * cosh_b, cos_a * sinh_b),
            // cosh(a+ib) = cosh a·cos b + i·sinh a·sin b
            C::new(cosh_a * cos_b, sinh_a * sin_b),
            // sinh(a+ib) = sinh a·cos b + i·cosh a·sin b
            C::new(sinh_a * cos_b, cosh_a * sin_b),
        ]
    }
}
