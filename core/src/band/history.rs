//! The samples a filter of the band still needs, in a line, and the sum a filter takes over
//! them: every filter of the band (the band-pass, the lower edge's low-pass and each half-band,
//! down and up) runs on these; and the delay the lower edge's complement holds the band-pass's
//! output in.
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

/// Up to `CAP` samples, oldest first, in `Line<[T; CAP]>`; its work is done as `Line<[T]>`, which
/// every line, whatever its length, derefs to: one copy of the code for all. Dropping from the
/// front only moves a start mark; the samples are moved back to the front when a block no longer
/// fits behind them, once in several blocks where `CAP` leaves room for several.
#[derive(Clone, Copy)]
pub struct Line<S: ?Sized> {
    start: usize,
    end: usize,
    samples: S,
}

impl<T: Copy, const CAP: usize> Line<[T; CAP]> {
    /// Empty, its room filled with `zero`: in a const, a static of lines lies in the zeroed
    /// RAM and takes no flash.
    pub const fn empty(zero: T) -> Self {
        Line { start: 0, end: 0, samples: [zero; CAP] }
    }
}

impl<T, const CAP: usize> core::ops::Deref for Line<[T; CAP]> {
    type Target = Line<[T]>;
    fn deref(&self) -> &Line<[T]> {
        self
    }
}

impl<T, const CAP: usize> core::ops::DerefMut for Line<[T; CAP]> {
    fn deref_mut(&mut self) -> &mut Line<[T]> {
        self
    }
}

impl<T: Real> Line<[T]> {
    /// `len` zeros, in place: a history at rest.
    pub fn rest(&mut self, len: usize) {
        assert!(len <= self.samples.len(), "a line of {len} in {}", self.samples.len());
        self.samples[..len].fill(T::zero());
        (self.start, self.end) = (0, len);
    }

    #[inline(always)]
    pub fn len(&self) -> usize {
        self.end - self.start
    }

    #[inline(always)]
    pub fn as_slice(&self) -> &[T] {
        &self.samples[self.start..self.end]
    }

    #[inline(always)]
    pub fn as_mut_slice(&mut self) -> &mut [T] {
        &mut self.samples[self.start..self.end]
    }

    /// `xs[0]`, `xs[2]`, `xs[4]`, … on the end: one input of each pair of a half-band's.
    #[inline(never)]
    pub fn extend_every_second(&mut self, xs: &[T]) {
        let n = xs.len().div_ceil(2);
        self.make_room(n);
        let to = &mut self.samples[self.end..self.end + n];
        for (s, pair) in to.iter_mut().zip(xs.chunks_exact(2)) {
            *s = pair[0];
        }
        if xs.len() % 2 == 1 {
            to[n - 1] = xs[xs.len() - 1];
        }
        self.end += n;
    }

    /// `xs` on the end and as many off the front into `out` as it holds, each sample moved once
    /// (those `out` takes from `xs` never enter the line).
    pub fn pass(&mut self, xs: &[T], out: &mut [T]) {
        let kept = self.len().min(out.len());
        out[..kept].copy_from_slice(&self.as_slice()[..kept]);
        self.drop_front(kept);
        let through = out.len() - kept;
        out[kept..].copy_from_slice(&xs[..through]);
        self.extend(&xs[through..]);
    }

    #[inline(always)]
    pub fn extend(&mut self, xs: &[T]) {
        self.make_room(xs.len());
        self.samples[self.end..self.end + xs.len()].copy_from_slice(xs);
        self.end += xs.len();
    }

    /// Forgets the oldest `n`.
    #[inline(always)]
    pub fn drop_front(&mut self, n: usize) {
        self.start += n;
    }

    #[inline(always)]
    fn make_room(&mut self, n: usize) {
        if self.end + n > self.samples.len() {
            self.move_to_front();
        }
    }

    /// The samples kept moved to the front, one by one: a few each time for most lines, where a
    /// call to `memmove` cost more than the move.
    #[inline(never)]
    fn move_to_front(&mut self) {
        let len = self.end - self.start;
        for i in 0..len {
            self.samples[i] = self.samples[self.start + i];
        }
        (self.start, self.end) = (0, len);
    }
}

/// A delay of up to `CAP` samples in `Delay<[T; CAP]>`, in a ring: each sample goes in as the one
/// from `len` samples before comes out, nothing moved. Its work is done as `Delay<[T]>`, as a
/// [`Line`]'s.
#[derive(Clone, Copy)]
pub struct Delay<S: ?Sized> {
    at: usize,
    len: usize,
    samples: S,
}

impl<T: Copy, const CAP: usize> Delay<[T; CAP]> {
    /// No delay, its room filled with `zero`, in a const ([`Line::empty`]).
    pub const fn empty(zero: T) -> Self {
        Delay { at: 0, len: 0, samples: [zero; CAP] }
    }
}

impl<T, const CAP: usize> core::ops::Deref for Delay<[T; CAP]> {
    type Target = Delay<[T]>;
    fn deref(&self) -> &Delay<[T]> {
        self
    }
}

impl<T, const CAP: usize> core::ops::DerefMut for Delay<[T; CAP]> {
    fn deref_mut(&mut self) -> &mut Delay<[T]> {
        self
    }
}

impl<T: Real> Delay<[T]> {
    /// `len` zeros, in place.
    pub fn rest(&mut self, len: usize) {
        assert!(len <= self.samples.len(), "a delay of {len} in {}", self.samples.len());
        self.samples[..len].fill(T::zero());
        (self.at, self.len) = (0, len);
    }

    /// Each of `buf` in, delayed, less its `less`: `buf[i]` ← the sample `len` before it −
    /// `less[i]`. A delay of at least one sample.
    #[inline(never)]
    pub fn less(&mut self, buf: &mut [T], less: &[T]) {
        let mut less = &less[..buf.len()];
        let mut buf = buf;
        // In runs up to the ring's end, where it wraps.
        while !buf.is_empty() {
            let run = (self.len - self.at).min(buf.len());
            let (now, later) = core::mem::take(&mut buf).split_at_mut(run);
            for ((v, l), h) in now.iter_mut().zip(&less[..run]).zip(&mut self.samples[self.at..self.at + run]) {
                (*h, *v) = (*v, *h - *l);
            }
            (buf, less) = (later, &less[run..]);
            self.at += run;
            if self.at == self.len {
                self.at = 0;
            }
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

/// The sums over `taps` of the `n` windows that start at `line[0]`, `line[1]`, …, handed to
/// `emit` with their window's start: four windows at a time where four are left. In line in
/// each stage (so `emit` costs nothing), around one [`dot_four`] out of line that all share.
#[inline(always)]
pub fn each_window<T: Real>(taps: &[T], line: &[T], n: usize, mut emit: impl FnMut(usize, T)) {
    let span = taps.len();
    let mut i = 0;
    while i + 4 <= n {
        for (j, y) in dot_four(taps, &line[i..i + span + 3]).into_iter().enumerate() {
            emit(i + j, y);
        }
        i += 4;
    }
    for i in i..n {
        emit(i, dot(taps, &line[i..i + span]));
    }
}

/// A filter over `input` whose earlier inputs `line` holds (as many as its taps less one): its
/// outputs into `out`; returns their number. The band-pass and the lower edge's low-pass, each at
/// its rate, share this one copy.
#[inline(never)]
pub fn fir<T: Real>(taps: &[T], line: &mut Line<[T]>, input: &[T], out: &mut [T]) -> usize {
    let n = input.len();
    line.extend(input);
    let out = &mut out[..n];
    each_window(taps, line.as_slice(), n, |i, y| out[i] = y);
    line.drop_front(n);
    n
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
    fn delays_by_its_length() {
        let mut d = super::Delay::<[f64; 8]>::empty(0.0);
        d.rest(3);
        let mut out: std::vec::Vec<f64> = (1..=7).map(|i| i as f64).collect();
        let (first, rest) = out.split_at_mut(2);
        d.less(first, &[0.5, 0.5]);
        d.less(rest, &[0.0, 1.0, 0.0, 0.0, 0.0]);
        assert_eq!(out, [-0.5, -0.5, 0.0, 0.0, 2.0, 3.0, 4.0]);
    }

    #[test]
    fn keeps_what_is_left() {
        let mut l = Line::<[f64; 8]>::empty(0.0);
        l.rest(2);
        l.extend(&[1.0, 2.0, 3.0]);
        l.extend_every_second(&[4.0, 0.0, 5.0]);
        l.drop_front(3);
        assert_eq!(l.as_slice(), &[2.0, 3.0, 4.0, 5.0]);
        l.extend_every_second(&[6.0, 0.0, 7.0, 0.0, 8.0, 0.0]);
        assert_eq!(l.as_slice(), &[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
        let mut out = [0.0; 4];
        l.pass(&[9.0, 10.0], &mut out);
        assert_eq!((out, l.as_slice()), ([2.0, 3.0, 4.0, 5.0], &[6.0, 7.0, 8.0, 9.0, 10.0][..]));
        let mut out = [0.0; 7];
        l.pass(&[11.0, 12.0, 13.0], &mut out);
        assert_eq!((out, l.as_slice()), ([6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0], &[13.0][..]));
    }
}
