//! The sine and cosine of an f32, computed in f32: what [`Real`](super::real::Real)'s `sin`, `cos`
//! and `sin_cos` are for f32, on the device and on the host alike (the same operations, so the
//! same bits).
//!
//! Why not libm's `sinf`: it reduces its argument with a Payne–Hanek path for any |x| up to f32's
//! largest and evaluates its kernels in f64, which the Cortex-M4's FPU does not have (4.6 KiB of
//! flash with the soft f64, and about 1 300 instructions a call). The core's angles are phases of
//! a design (ωT ≤ π, a delay of a few samples, a pole's angle), which the f32 path here covers.
//!
//! How: k = x·2/π rounded, r = x − k·π/2 with π/2 in four parts (Cody–Waite), so that k·part is
//! exact while |k| ≤ 2¹², and r kept as r + lo (two-sums); beyond |x| = [`F32_REDUCTION_MAX`]
//! the same reduction in f64 (π/2 in three parts of 33, 33 and 53 bits). On |r| ≤ π/4 (and a
//! little more, for the rounding of k): sin r = r + r³·S(r²) and cos r = 1 − r²/2 + r⁴·C(r²), S
//! and C of degree 2, minimax over r² ≤ (π/4 + 2⁻¹⁰)² (Remez; relative error of sin 6.2·10⁻⁹,
//! absolute of cos 2.0·10⁻¹⁰ before rounding to f32), then the quadrant k mod 4.
//!
//! Error, against libm's f64 sine and cosine: at most 1.39 ulp of the result for every f32 of
//! 2⁻¹² ≤ |x| ≤ 1.6·10⁶ (the ignored test below runs them all; 95 % within half an ulp),
//! exact below; the tests hold a sample of them to 1.5 ulp. Up to [`MAX_ARGUMENT`] the f64
//! reduction's error grows as |x|·2⁻⁵³. Beyond it, where an f32's spacing (≥ 128) is more than
//! twenty periods, the result is NaN, as it is for ±∞ and NaN. sin(±0) = ±0.

/// Where the f32 reduction ends: |k| ≤ 2¹² keeps each k·part exact.
pub const F32_REDUCTION_MAX: f32 = 6433.0;
/// The largest |x| with a result.
pub const MAX_ARGUMENT: f32 = 1073741824.0; // 2^30

/// π/2 = P1 + P2 + P3 + P4 (to 2·10⁻²¹): P1, P2 and P3 of 12 significant bits each, P4 the rest
/// rounded to f32.
const P1: f32 = 1.570_800_781_25;
const P2: f32 = -4.453_584_551_811_218e-6;
const P3: f32 = -8.706_138_032_721_356e-10;
const P4: f32 = 6.223_371_969_669_989e-14;
/// π/2 = Q1 + Q2 + Q3 in f64: Q1 and Q2 of 33 significant bits (k·Q exact for |k| < 2²⁰).
const Q1: f64 = 1.570_796_326_734_125_6;
const Q2: f64 = 6.077_100_506_303_966e-11;
const Q3: f64 = 2.022_266_248_795_950_6e-21;

/// sin r = r + r³·(S1 + r²·(S2 + r²·S3)) on |r| ≤ π/4 + 2⁻¹⁰.
const S1: f32 = -0.166_666_552_424_430_85;
const S2: f32 = 0.008_332_095_108_926_296;
const S3: f32 = -0.000_195_031_301_700_510_08;
/// cos r = 1 − r²/2 + r⁴·(C1 + r²·(C2 + r²·C3)) on the same range.
const C1: f32 = 0.041_666_653_007_268_906;
const C2: f32 = -0.001_388_764_823_786_914_3;
const C3: f32 = 2.446_300_277_370_028_2e-5;

/// Added to and taken away from a value below 2²² (2⁵¹), it rounds it to an integer.
const ROUND_F32: f32 = 12_582_912.0; // 1.5 * 2^23
const ROUND_F64: f64 = 6_755_399_441_055_744.0; // 1.5 * 2^52

/// Below this |x|, sin x rounds to x and cos x to 1.
const TINY: f32 = 2.441_406_25e-4; // 2^-12

/// (sin x, cos x).
#[inline(never)]
pub fn sin_cos(x: f32) -> (f32, f32) {
    let a = x.abs();
    if a < TINY {
        return (x, 1.0);
    }
    // r + lo: the reduced argument, and what rounding r to f32 left of it.
    let (r, lo, quadrant) = if a <= F32_REDUCTION_MAX {
        // k, rounded by adding and taking away 1.5·2²³ (exact for |k| < 2²²); the sum's last bits
        // are k mod 4.
        let shifted = x * core::f32::consts::FRAC_2_PI + ROUND_F32;
        let kf = shifted - ROUND_F32;
        // x − k·P1, k·P2 and k·P3 are exact; the differences' rounding errors are kept.
        let (d, e) = two_diff(x - kf * P1, kf * P2);
        let (d, e2) = two_diff(d, kf * P3);
        let rest = (e + e2) - kf * P4;
        let r = d + rest;
        (r, (d - r) + rest, shifted.to_bits())
    } else if a < MAX_ARGUMENT {
        let xd = x as f64;
        let shifted = xd * core::f64::consts::FRAC_2_PI + ROUND_F64;
        let kd = shifted - ROUND_F64;
        let rd = ((xd - kd * Q1) - kd * Q2) - kd * Q3;
        let r = rd as f32;
        (r, (rd - r as f64) as f32, shifted.to_bits() as u32)
    } else {
        return (f32::NAN, f32::NAN);
    };
    // sin(r + lo) = sin r + lo·cos r, cos(r + lo) = cos r − lo·sin r, to first order in lo.
    let t = r * r;
    let s = r + (r * t * (S1 + t * (S2 + t * S3)) + lo * (1.0 - 0.5 * t));
    let c = 1.0 - (t * (0.5 - t * (C1 + t * (C2 + t * C3))) + r * lo);
    match quadrant & 3 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

/// sin x (the pair's first: one function in flash for all three).
#[inline(always)]
pub fn sin(x: f32) -> f32 {
    sin_cos(x).0
}

/// cos x.
#[inline(always)]
pub fn cos(x: f32) -> f32 {
    sin_cos(x).1
}

/// a − b and its rounding error, exactly (Knuth's two-sum).
#[inline(always)]
fn two_diff(a: f32, b: f32) -> (f32, f32) {
    let d = a - b;
    let z = d - a;
    (d, (a - (d - z)) - (b + z))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |got − want| in units of the last place of f32 at `want` (the f64 reference).
    fn ulps(got: f32, want: f64) -> f64 {
        let rounded = want as f32;
        let ulp =
            if rounded == 0.0 { f32::MIN_POSITIVE as f64 } else { (f32::from_bits(rounded.abs().to_bits() + 1) - rounded.abs()) as f64 };
        (got as f64 - want).abs() / ulp
    }

    /// The worst error over every `stride`-th f32 from `lo` up to `hi` (both positive) and their
    /// negatives.
    fn worst(lo: f32, hi: f32, stride: u32) -> f64 {
        let mut worst = 0.0f64;
        let mut bits = lo.to_bits();
        while bits <= hi.to_bits() {
            for x in [f32::from_bits(bits), -f32::from_bits(bits)] {
                let (s, c) = sin_cos(x);
                let xd = x as f64;
                worst = worst.max(ulps(s, libm::sin(xd))).max(ulps(c, libm::cos(xd)));
            }
            bits += stride;
        }
        worst
    }

    #[test]
    fn within_one_and_a_half_ulp_on_the_f32_reduction() {
        // Every 97th f32 from 2^-20 to the end of the f32 reduction: 10 million arguments.
        let w = worst(9.5e-7, F32_REDUCTION_MAX, 97);
        assert!(w <= 1.5, "worst {w} ulp");
    }

    #[test]
    fn within_one_and_a_half_ulp_on_the_f64_reduction() {
        let w = worst(F32_REDUCTION_MAX, 1.6e6, 31);
        assert!(w <= 1.5, "worst {w} ulp");
    }

    /// The stated bound on every f32 of the range, both signs.
    #[test]
    #[ignore = "every f32 of 2^-12 ≤ |x| ≤ 1.6·10^6: 90 s built for release"]
    fn every_argument_within_the_stated_bound() {
        let w = worst(TINY, 1.6e6, 1);
        assert!(w <= 1.39, "worst {w} ulp");
    }

    #[test]
    fn the_reductions_error_grows_with_the_argument_only() {
        // Up to 2^30 the reduction's absolute error stays near |x|·2^-53: here below 2·10^-7.
        let mut bits = 1.6e6f32.to_bits();
        while bits < MAX_ARGUMENT.to_bits() {
            let x = f32::from_bits(bits);
            let (s, c) = sin_cos(x);
            let xd = x as f64;
            let e = (s as f64 - libm::sin(xd)).abs().max((c as f64 - libm::cos(xd)).abs());
            assert!(e < 2e-7, "x = {x}: error {e}");
            bits += 1001;
        }
    }

    #[test]
    fn zeros_tiny_arguments_and_the_edges() {
        assert_eq!(sin_cos(0.0).0.to_bits(), 0.0f32.to_bits());
        assert_eq!(sin_cos(-0.0).0.to_bits(), (-0.0f32).to_bits());
        assert_eq!(sin_cos(-0.0).1, 1.0);
        for x in [1e-30f32, -3e-6, 2.4e-4, -2.44e-4, f32::MIN_POSITIVE, 1e-45] {
            assert_eq!(sin_cos(x), (x, 1.0), "x = {x}");
            assert!(ulps(sin_cos(x).0, libm::sin(x as f64)) <= 0.5);
        }
        for x in [f32::INFINITY, f32::NEG_INFINITY, f32::NAN, MAX_ARGUMENT, -2e9, f32::MAX] {
            let (s, c) = sin_cos(x);
            assert!(s.is_nan() && c.is_nan(), "x = {x}");
        }
        // The quadrants' signs at multiples of π/2 and between them.
        let h = core::f32::consts::FRAC_PI_2;
        for (k, want) in [(1.0f32, (1.0f32, 0.0f32)), (2.0, (0.0, -1.0)), (3.0, (-1.0, 0.0)), (4.0, (0.0, 1.0)), (-1.0, (-1.0, 0.0))] {
            let (s, c) = sin_cos(k * h);
            assert!((s - want.0).abs() < 1e-6 && (c - want.1).abs() < 1e-6, "{k}·π/2: ({s}, {c})");
        }
    }
}
