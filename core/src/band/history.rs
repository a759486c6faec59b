//! The samples a filter of the band still needs, in a line, and the sum a filter takes over
//! them: every filter of the band (the band-pass and each half-band, down and up) runs on these.
//!
//! The filters run a block at a time: each stage's new samples go on the end of its line, its
//! outputs are computed over the whole line in one loop, and the samples no later output needs
//! are dropped from the front. Per block, the calls, the index arithmetic and the move are paid
//! once, not per sample; what is left per sample is the sum over the taps, taken over four
//! neighbouring windows at once so that every tap and sample loaded serves four outputs: what
//! the cost of the band on the device comes down to. (Folding a symmetric filter's pairs first
//! halves its multiplies but walks one end of the window backwards; on the M4 the address
//! arithmetic that costs ate the saving.)

use crate::numeric::real::Real;

/// Up to `CAP` samples, oldest first. Dropping from the front only moves a start mark; the
/// samples are moved back to the front when a block no longer fits behind them, once in several
/// blocks where `CAP` leaves room for several.
#[derive(Clone, Copy)]
pub struct Line<T, const CAP: usize> {
    samples: [T; CAP],
    start: usize,
    end: usize,
}

impl<T: Real, const CAP: usize> Line<T, CAP> {
    /// `len` zeros: a history at rest.
    pub fn zeros(len: usize) -> Self {
        assert!(len <= CAP, "a line of {len} in {CAP}");
        Line { samples: [T::zero(); CAP], start: 0, end: len }
    }

    pub fn len(&self) -> usize {
        self.end - self.start
    }

    pub fn as_slice(&self) -> &[T] {
        &self.samples[self.start..self.end]
    }

    pub fn push(&mut self, x: T) {
        self.make_room(1);
        self.samples[self.end] = x;
        self.end += 1;
    }

    pub fn extend(&mut self, xs: &[T]) {
        self.make_room(xs.len());
        self.samples[self.end..self.end + xs.len()].copy_from_slice(xs);
        self.end += xs.len();
    }

    /// Forgets the oldest `n`.
    pub fn drop_front(&mut self, n: usize) {
        self.start += n;
    }

    fn make_room(&mut self, n: usize) {
        if self.end + n > CAP {
            self.samples.copy_within(self.start..self.end, 0);
            (self.start, self.end) = (0, self.end - self.start);
        }
    }
}

/// Σ h[j]·w[j]: one output of a filter whose window is `w`.
#[inline(always)]
pub fn dot<T: Real>(h: &[T], w: &[T]) -> T {
    let mut acc = T::zero();
    for (h, w) in h.iter().zip(w) {
        acc += *h * *w;
    }
    acc
}

/// [`dot`] over four neighbouring windows at once, `w[..n]`, `w[1..n + 1]`, … (`w` is
/// `h.len() + 3` long): each tap and sample loaded serves four outputs, so a tap costs a
/// multiply and half a load. Each output is accumulated in the same order as [`dot`] takes it,
/// so that it has the same bits whichever of the two makes it. Out of line: one copy serves
/// every stage, for the flash its unrolled loop takes.
#[inline(never)]
pub fn dot_four<T: Real>(h: &[T], w: &[T]) -> [T; 4] {
    let mut acc = [T::zero(); 4];
    let (mut w0, mut w1, mut w2) = (w[0], w[1], w[2]);
    let (h4, w4) = (h.chunks_exact(4), w[3..].chunks_exact(4));
    let (hr, wr) = (h4.remainder(), w4.remainder());
    // Four taps a step, so that the three samples carried to the next tap stay in registers.
    for (h, w) in h4.zip(w4) {
        let [w3, w4, w5, w6] = [w[0], w[1], w[2], w[3]];
        for (hj, [a, b, c, d]) in [(h[0], [w0, w1, w2, w3]), (h[1], [w1, w2, w3, w4]), (h[2], [w2, w3, w4, w5]), (h[3], [w3, w4, w5, w6])] {
            acc[0] += hj * a;
            acc[1] += hj * b;
            acc[2] += hj * c;
            acc[3] += hj * d;
        }
        (w0, w1, w2) = (w4, w5, w6);
    }
    for (hj, &w3) in hr.iter().zip(wr) {
        acc[0] += *hj * w0;
        acc[1] += *hj * w1;
        acc[2] += *hj * w2;
        acc[3] += *hj * w3;
        (w0, w1, w2) = (w1, w2, w3);
    }
    acc
}

#[cfg(test)]
mod tests {
    use super::{Line, dot, dot_four};

    #[test]
    fn four_windows_at_once_as_one_at_a_time() {
        let x: std::vec::Vec<f64> = (1..=20).map(|i| (i as f64 * 0.7).sin()).collect();
        for taps in [1, 3, 4, 7, 8, 13] {
            let h: std::vec::Vec<f64> = (0..taps).map(|j| 1.0 + j as f64 / 3.0).collect();
            let four = dot_four(&h, &x[2..taps + 5]);
            for (i, y) in four.iter().enumerate() {
                // Bit for bit: the same products added in the same order.
                assert_eq!(y.to_bits(), dot(&h, &x[2 + i..]).to_bits(), "{taps} taps, window {i}");
            }
        }
        assert_eq!(dot(&[1.0, 10.0, 100.0], &[3.0, 2.0, 1.0]), 123.0);
    }

    #[test]
    fn keeps_what_is_left() {
        let mut l = Line::<f64, 8>::zeros(2);
        l.extend(&[1.0, 2.0, 3.0]);
        l.push(4.0);
        l.drop_front(3);
        assert_eq!(l.as_slice(), &[2.0, 3.0, 4.0]);
    }
}
