//! Detection of a stuck current input: the same value sample after sample for longer than a live
//! front end can produce it (a hung ADC or DMA, a disconnected amplifier at a rail). The
//! amplifier's noise alone moves a live 12-bit reading by a code every few samples, so a run of
//! identical values as long as [`StuckDetector::new`]'s is not a signal (at a 0.9 chance of an
//! unchanged code per sample, 2000 in a row happen with probability 1e-92).

use crate::Real;

/// Counts consecutive identical samples across blocks.
#[derive(Clone, Copy, Debug)]
pub struct StuckDetector<T> {
    last: T,
    run: u32,
    run_limit: u32,
}

impl<T: Real> StuckDetector<T> {
    /// Flags a run of at least `run_limit` identical samples (the firmware uses one second).
    pub fn new(run_limit: u32) -> Self {
        StuckDetector { last: T::nan(), run: 0, run_limit: run_limit.max(1) }
    }

    /// Looks at the next block; true while the input has been stuck for `run_limit` samples or
    /// more (it clears at the first sample that differs).
    pub fn observe(&mut self, block: &[T]) -> bool {
        for &v in block {
            // NaN never equals itself: a NaN input starts a new run instead of extending one.
            if v == self.last {
                self.run = self.run.saturating_add(1);
            } else {
                self.last = v;
                self.run = 1;
            }
        }
        self.run >= self.run_limit
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flags_a_long_run_only_and_clears() {
        let mut d = StuckDetector::<f32>::new(100);
        let live: [f32; 32] = core::array::from_fn(|k| (k % 3) as f32);
        for _ in 0..10 {
            assert!(!d.observe(&live));
        }
        let stuck = [0.5f32; 32];
        let flags: [bool; 4] = core::array::from_fn(|_| d.observe(&stuck));
        assert_eq!(flags, [false, false, false, true]); // 96 then 128 identical samples
        assert!(!d.observe(&live));
        assert!(!d.observe(&[f32::NAN; 32]));
    }
}
