//! In-place radix-2 FFT for the running spectrum ([`crate::running_spectrum`]): one fixed size,
//! twiddles computed once, no allocation, so the device and the host run the same arithmetic.

use crate::{C, Real};

/// The transform's length (a power of two) and its twiddle factors e^(−2πik/N), k < N/2.
pub struct Fft<T, const N: usize> {
    twiddle: [C<T>; N],
}

impl<T: Real, const N: usize> Fft<T, N> {
    pub fn new() -> Self {
        assert!(N.is_power_of_two() && N >= 2, "the FFT's length must be a power of two");
        let mut twiddle = [C::new(T::zero(), T::zero()); N];
        for (k, w) in twiddle.iter_mut().enumerate().take(N / 2) {
            // Each twiddle from its own angle: a recurrence would build up rounding in f32.
            let (s, c) = (T::lit(-2.0 * core::f64::consts::PI * k as f64 / N as f64)).sin_cos();
            *w = C::new(c, s);
        }
        Fft { twiddle }
    }

    /// X_k = Σ x_n e^(−2πikn/N), in place.
    pub fn forward(&self, x: &mut [C<T>; N]) {
        let bits = N.trailing_zeros();
        for i in 0..N {
            let j = i.reverse_bits() >> (usize::BITS - bits);
            if j > i {
                x.swap(i, j);
            }
        }
        let mut len = 2;
        while len <= N {
            let step = N / len;
            for start in (0..N).step_by(len) {
                for k in 0..len / 2 {
                    let w = self.twiddle[k * step];
                    let a = x[start + k];
                    let b = x[start + k + len / 2] * w;
                    x[start + k] = a + b;
                    x[start + k + len / 2] = a - b;
                }
            }
            len *= 2;
        }
    }
}

impl<T: Real, const N: usize> Default for Fft<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_direct_sum() {
        const N: usize = 64;
        let mut x = [C::new(0.0f64, 0.0); N];
        for (n, v) in x.iter_mut().enumerate() {
            *v = C::new((n as f64 * 0.37).sin() + 0.1 * n as f64, (n as f64 * 1.3).cos());
        }
        let direct: std::vec::Vec<C<f64>> = (0..N)
            .map(|k| {
                x.iter().enumerate().fold(C::new(0.0, 0.0), |acc, (n, &v)| {
                    let a = -2.0 * core::f64::consts::PI * (k * n) as f64 / N as f64;
                    acc + v * C::new(a.cos(), a.sin())
                })
            })
            .collect();
        Fft::<f64, N>::new().forward(&mut x);
        for (a, b) in x.iter().zip(&direct) {
            assert!((a - b).norm() < 1e-12, "{a} {b}");
        }
    }
}
