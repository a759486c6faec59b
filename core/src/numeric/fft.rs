//! FFT of a real sequence for the running spectrum ([`crate::humidity::spectrum`]): its 2H samples
//! packed as H complex ones (even samples real, odd imaginary), an in-place transform of those,
//! and the bins wanted split out of it. Half the work of a complex transform of 2H points, which
//! is what keeps the spectrum within its budget per sample on the device. One fixed size, twiddles
//! computed once, no allocation, so the device and the host run the same arithmetic.
//!
//! The transform is radix 4 (one radix-2 pass first when H is an odd power of two): a quarter
//! fewer multiplications than radix 2 and half the passes over memory. Its input goes to
//! bit-reversed slots as it is loaded ([`RealFft::slot`]), so no pass reorders it; a radix-4
//! pass over bit-reversed data finds the sub-transforms of residues 0, 2, 1, 3 in its four
//! quarters, and takes them in that order.

use crate::{C, Real};

/// A real FFT of 2H points, `H` a power of two.
pub struct RealFft<T, const H: usize> {
    /// Per radix-4 pass of length 4M, for k < M: W^k, W^2k, W^3k with W = e^(−2πi/4M), the passes
    /// one after another (3·M entries each, fewer than H in all).
    passes: [C<T>; H],
    /// −j·e^(−2πik/2H), k < H: the split's twiddles, with the split's −j taken in.
    split: [C<T>; H],
}

/// e^(−2πi·k/n) in `T`, from its own angle: a recurrence would build up rounding in f32.
fn root<T: Real>(k: usize, n: usize) -> C<T> {
    let (s, c) = T::lit(-2.0 * core::f64::consts::PI * k as f64 / n as f64).sin_cos();
    C::new(c, s)
}

impl<T: Real, const H: usize> RealFft<T, H> {
    /// The sub-transform length after the first pass: 2 after a radix-2 pass, 4 after a radix-4
    /// one (whose twiddles are all 1).
    const FIRST: usize = if H.trailing_zeros() % 2 == 1 { 2 } else { 4 };

    pub fn new() -> Self {
        assert!(H.is_power_of_two() && H >= 2, "the FFT's half length must be a power of two");
        let mut passes = [C::new(T::zero(), T::zero()); H];
        let mut at = 0;
        let mut m = Self::FIRST;
        while m < H {
            for k in 0..m {
                for (q, w) in passes[at..at + 3].iter_mut().enumerate() {
                    *w = root((q + 1) * k, 4 * m);
                }
                at += 3;
            }
            m *= 4;
        }
        let mut split = [C::new(T::zero(), T::zero()); H];
        for (k, w) in split.iter_mut().enumerate() {
            let r = root::<T>(k, 2 * H);
            *w = C::new(r.im, -r.re);
        }
        RealFft { passes, split }
    }

    /// Where the packed sample n (x_{2n} + j·x_{2n+1}) goes before [`Self::transform`].
    #[inline(always)]
    pub fn slot(n: usize) -> usize {
        n.reverse_bits() >> (usize::BITS - H.trailing_zeros())
    }

    /// Z_k = Σ z_n e^(−2πikn/H), in place, of z_n loaded at `slot(n)`.
    pub fn transform(&self, z: &mut [C<T>; H]) {
        if Self::FIRST == 2 {
            for pair in z.chunks_exact_mut(2) {
                let (a, b) = (pair[0], pair[1]);
                pair[0] = a + b;
                pair[1] = a - b;
            }
        } else {
            for quad in z.chunks_exact_mut(4) {
                let [a, b, c, d] = [quad[0], quad[1], quad[2], quad[3]];
                let out = butterfly(a, c, b, d);
                quad.copy_from_slice(&out);
            }
        }
        let mut m = Self::FIRST;
        let mut twiddles: &[C<T>] = &self.passes;
        while m < H {
            let (these, rest) = twiddles.split_at(3 * m);
            for block in z.chunks_exact_mut(4 * m) {
                let (q0, rest) = block.split_at_mut(m);
                let (q1, rest) = rest.split_at_mut(m);
                let (q2, q3) = rest.split_at_mut(m);
                let quarters = q0.iter_mut().zip(q1.iter_mut()).zip(q2.iter_mut()).zip(q3.iter_mut());
                for ((((a, b), c), d), w) in quarters.zip(these.chunks_exact(3)) {
                    // Residue 1 is in the third quarter, residue 2 in the second.
                    let [x0, x1, x2, x3] = butterfly(*a, *c * w[0], *b * w[1], *d * w[2]);
                    (*a, *b, *c, *d) = (x0, x1, x2, x3);
                }
            }
            twiddles = rest;
            m *= 4;
        }
    }

    /// |X_k|² for k = first, first + 1, … of the real sequence whose packed transform is `z`,
    /// with X_k = Σ x_n e^(−2πikn/2H): handed to `each` with the element of `out` in its place
    /// (0 < first, first + out.len() ≤ H).
    #[inline(always)]
    pub fn powers(&self, z: &[C<T>; H], first: usize, out: &mut [T], mut each: impl FnMut(&mut T, T)) {
        let n = out.len();
        let (lo, w) = (&z[first..first + n], &self.split[first..first + n]);
        // Z_{H−k} for k = first + n − 1 down to first.
        let mirrored = &z[H + 1 - first - n..=H - first];
        let quarter = T::lit(0.25);
        for i in 0..n {
            let (zk, zc) = (lo[i], mirrored[n - 1 - i].conj());
            // 2X_k = (Z_k + Z*_{H−k}) − j·e^(−2πik/2H)·(Z_k − Z*_{H−k})
            let x2 = (zk + zc) + w[i] * (zk - zc);
            each(&mut out[i], x2.norm_sqr() * quarter);
        }
    }
}

/// One radix-4 butterfly: the transform of length 4M at k, k + M, k + 2M, k + 3M from the four
/// sub-transforms of residues 0 … 3, each already times its twiddle.
#[inline(always)]
fn butterfly<T: Real>(a0: C<T>, a1: C<T>, a2: C<T>, a3: C<T>) -> [C<T>; 4] {
    let (t0, t1) = (a0 + a2, a0 - a2);
    let (t2, t3) = (a1 + a3, a1 - a3);
    // −j·t3
    let t3j = C::new(t3.im, -t3.re);
    [t0 + t2, t1 + t3j, t0 - t2, t1 - t3j]
}

impl<T: Real, const H: usize> Default for RealFft<T, H> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// |X_k|² of the FFT against the direct sum, for a half length of either parity of log2.
    fn matches_the_direct_sum<const H: usize>() {
        let x: std::vec::Vec<f64> = (0..2 * H).map(|n| (n as f64 * 0.37).sin() + 0.1 * n as f64 + (n as f64 * 1.3).cos()).collect();
        let mut z = [C::new(0.0f64, 0.0); H];
        for n in 0..H {
            z[RealFft::<f64, H>::slot(n)] = C::new(x[2 * n], x[2 * n + 1]);
        }
        let fft = RealFft::<f64, H>::new();
        fft.transform(&mut z);
        let mut got = [0.0; H];
        fft.powers(&z, 1, &mut got[1..], |out, p| *out = p);
        for k in 1..H {
            let p = got[k];
            let direct = x.iter().enumerate().fold(C::new(0.0, 0.0), |acc, (n, &v)| {
                let a = -2.0 * core::f64::consts::PI * (k * n) as f64 / (2 * H) as f64;
                acc + C::new(a.cos(), a.sin()) * v
            });
            let scale = direct.norm_sqr().max(1.0);
            assert!((p - direct.norm_sqr()).abs() < 1e-11 * scale, "H {H}, bin {k}: {p} vs {}", direct.norm_sqr());
        }
    }

    #[test]
    fn matches_the_direct_sum_radix_4_throughout() {
        matches_the_direct_sum::<64>();
        matches_the_direct_sum::<256>();
    }

    #[test]
    fn matches_the_direct_sum_after_a_radix_2_pass() {
        matches_the_direct_sum::<2>();
        matches_the_direct_sum::<32>();
        matches_the_direct_sum::<128>();
    }
}
