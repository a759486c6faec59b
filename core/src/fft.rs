//! FFT of a real sequence for the running spectrum ([`crate::running_spectrum`]): its 2H samples
//! packed as H complex ones (even samples real, odd imaginary), an in-place radix-2 transform of
//! those, and the bins wanted split out of it. Half the work of a complex transform of 2H points,
//! which is what keeps the spectrum within its budget per sample on the device. One fixed size,
//! twiddles computed once, no allocation, so the device and the host run the same arithmetic.

use crate::{C, Real};

/// A real FFT of 2H points, `H` a power of two: the twiddle factors e^(−2πik/2H), k < H, serve
/// both the H-point complex transform (every (2H/len)-th for a stage of length `len`) and the
/// split.
pub struct RealFft<T, const H: usize> {
    twiddle: [C<T>; H],
}

impl<T: Real, const H: usize> RealFft<T, H> {
    pub fn new() -> Self {
        assert!(H.is_power_of_two() && H >= 2, "the FFT's half length must be a power of two");
        let mut twiddle = [C::new(T::zero(), T::zero()); H];
        for (k, w) in twiddle.iter_mut().enumerate() {
            // Each twiddle from its own angle: a recurrence would build up rounding in f32.
            let (s, c) = (T::lit(-core::f64::consts::PI * k as f64 / H as f64)).sin_cos();
            *w = C::new(c, s);
        }
        RealFft { twiddle }
    }

    /// Z_k = Σ z_n e^(−2πikn/H), in place: `z` holds x_{2n} + j·x_{2n+1}.
    pub fn transform(&self, z: &mut [C<T>; H]) {
        let bits = H.trailing_zeros();
        for i in 0..H {
            let j = i.reverse_bits() >> (usize::BITS - bits);
            if j > i {
                z.swap(i, j);
            }
        }
        // The first stage's twiddle is 1.
        for pair in z.chunks_exact_mut(2) {
            let (a, b) = (pair[0], pair[1]);
            pair[0] = a + b;
            pair[1] = a - b;
        }
        // The second's are 1 and −j.
        if H >= 4 {
            for quad in z.chunks_exact_mut(4) {
                let (a, b, c, d) = (quad[0], quad[1], quad[2], quad[3]);
                let dj = C::new(d.im, -d.re);
                quad[0] = a + c;
                quad[2] = a - c;
                quad[1] = b + dj;
                quad[3] = b - dj;
            }
        }
        let mut len = 8;
        while len <= H {
            let step = 2 * H / len;
            for chunk in z.chunks_exact_mut(len) {
                let (lo, hi) = chunk.split_at_mut(len / 2);
                for (k, (a, b)) in lo.iter_mut().zip(hi.iter_mut()).enumerate() {
                    let t = *b * self.twiddle[k * step];
                    let u = *a;
                    *a = u + t;
                    *b = u - t;
                }
            }
            len *= 2;
        }
    }

    /// X_k = Σ x_n e^(−2πikn/2H) of the real sequence, 0 ≤ k < H, from its packed transform `z`.
    pub fn bin(&self, z: &[C<T>; H], k: usize) -> C<T> {
        let zk = z[k];
        let zc = z[(H - k) % H].conj();
        let half = T::lit(0.5);
        let even = (zk + zc) * half;
        let d = (zk - zc) * half;
        // (zk − zc)/(2j) = −j·d
        let odd = C::new(d.im, -d.re);
        even + self.twiddle[k] * odd
    }
}

impl<T: Real, const H: usize> Default for RealFft<T, H> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_direct_sum() {
        const H: usize = 32;
        let x: std::vec::Vec<f64> = (0..2 * H).map(|n| (n as f64 * 0.37).sin() + 0.1 * n as f64 + (n as f64 * 1.3).cos()).collect();
        let mut z = [C::new(0.0f64, 0.0); H];
        for (n, v) in z.iter_mut().enumerate() {
            *v = C::new(x[2 * n], x[2 * n + 1]);
        }
        let fft = RealFft::<f64, H>::new();
        fft.transform(&mut z);
        for k in 0..H {
            let direct = x.iter().enumerate().fold(C::new(0.0, 0.0), |acc, (n, &v)| {
                let a = -2.0 * core::f64::consts::PI * (k * n) as f64 / (2 * H) as f64;
                acc + C::new(a.cos(), a.sin()) * v
            });
            let got = fft.bin(&z, k);
            assert!((got - direct).norm() < 1e-11, "bin {k}: {got} vs {direct}");
        }
    }
}
