//! The accelerometer's value at each ADC sample's instant. The part's samples arrive in bursts,
//! numbered by their place on the part's own clock (`k`, from its timestamps); they are kept in a
//! ring of the last [`RING`] samples. The ADC's samples are taken at the board's timer; each
//! instant, plus the configured delay of the part's filter chain (a part's sample shows the
//! signal of that much earlier), is mapped onto the part's sample numbers by the [`ClockMap`] and read there by the cubic [`interpolator`]. The place of
//! the next ADC sample on the part's clock is kept as a fixed-point number (32 bits of fraction)
//! and advanced by a fixed-point step, so that it never drifts; [`Resampler::retime`] sets both
//! again from the clock map, once a burst.
//!
//! A value is given only where the four samples around its instant are in the ring and contiguous:
//! across a gap (an overrun of the part's FIFO) or before the first samples, none.
//!
//! [`interpolator`]: super::interpolator

use super::{clock_map::ClockMap, interpolator::cubic};
use crate::numeric::real::Real;

/// Samples of the part kept: 256, 154 ms at 1.66 kHz, more than a burst (38 ms) and the wait
/// for the bus.
pub const RING: usize = 256;
const _: () = assert!(RING.is_power_of_two(), "the ring is indexed by a mask");
const FRACTION_BITS: u32 = 32;
const ONE: f64 = (1u64 << FRACTION_BITS) as f64;

/// The ring of recent samples and the place of the next ADC sample on the part's clock.
#[derive(Debug, Clone)]
pub struct Resampler<T> {
    ring: [T; RING],
    /// Number of the newest sample pushed, plus one (0: none yet).
    end: u64,
    /// Number of the first sample after the last gap.
    contiguous_from: u64,
    /// The next ADC sample's place on the part's clock, in samples × 2^32.
    place: u64,
    /// Part samples per ADC sample × 2^32.
    step: u64,
    timed: bool,
}

impl<T: Real> Default for Resampler<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T: Real> Resampler<T> {
    pub fn new() -> Self {
        Self { ring: [T::zero(); RING], end: 0, contiguous_from: 0, place: 0, step: 0, timed: false }
    }

    /// Adds the part's sample number `k` (samples since its timestamp's origin). Numbers go up; a
    /// number past the next one is a gap, and a number already passed is ignored.
    pub fn push(&mut self, k: u64, value: T) {
        if self.end > 0 && k < self.end {
            return;
        }
        if k != self.end {
            self.contiguous_from = k;
        }
        self.ring[(k & (RING as u64 - 1)) as usize] = value;
        self.end = k + 1;
    }

    /// Sets the place of the ADC sample taken at `board` on the board's timer, and the step to
    /// the next, `period` board counts later, from the clock map: `part_counts_per_sample`
    /// timestamp counts make one of the part's samples, whose sample 0 is at timestamp
    /// `part_origin`, and the part's filter chain delays its samples by `delay_counts` timestamp
    /// counts. Nothing before the map's first pair.
    pub fn retime(&mut self, map: &ClockMap, board: u64, period: f64, part_origin: u64, part_counts_per_sample: f64, delay_counts: f64) {
        let Some(part) = map.part_of(board as f64) else { return };
        // The part's sample taken `delay_counts` later shows the signal of this instant.
        let place = (part + delay_counts - part_origin as f64) / part_counts_per_sample;
        let step = period / map.rate() / part_counts_per_sample;
        if place < 0.0 {
            return;
        }
        self.place = (place * ONE) as u64;
        self.step = (step * ONE) as u64;
        self.timed = true;
    }

    /// The values at the next `out.len()` ADC samples' instants, and the place moves on by as
    /// many ADC periods. `false` (and `out` untouched) while the samples around them are not all
    /// there (not yet, or lost in a gap) or before the first [`Self::retime`]: a block is whole
    /// or not at all, which keeps the per-sample loop free of checks.
    pub fn next_block(&mut self, out: &mut [T]) -> bool {
        let place = self.place;
        let span = self.step.wrapping_mul(out.len() as u64);
        self.place = place.wrapping_add(span);
        if !self.timed || out.is_empty() {
            return false;
        }
        // Samples first − 1 … last + 2 must be in the ring, after the last gap.
        let first = place >> FRACTION_BITS;
        let last = (place + span - self.step) >> FRACTION_BITS;
        if first == 0 || first - 1 < self.contiguous_from || last + 2 >= self.end || self.end - (first - 1) > RING as u64 {
            return false;
        }
        let mask = RING as u64 - 1;
        let scale = T::lit(1.0 / 65536.0);
        let mut at = place;
        for v in out.iter_mut() {
            let i = at >> FRACTION_BITS;
            let x = |k: u64| self.ring[(k & mask) as usize];
            // The fraction's top 16 bits: a place to 15 ppm of a sample (8 ppm of a 150 Hz
            // tone's amplitude), from an integer the FPU converts, with no f64 on the device.
            let mu = T::from_u16((at >> (FRACTION_BITS - 16)) as u16) * scale;
            *v = cubic([x(i - 1), x(i), x(i + 1), x(i + 2)], mu);
            at = at.wrapping_add(self.step);
        }
        true
    }

    /// How far the newest sample is ahead of the next ADC sample's place [whole part samples]:
    /// the margin the bursts leave (negative: the ADC has caught up with the part's data).
    pub fn lead(&self) -> i64 {
        self.end as i64 - (self.place >> FRACTION_BITS) as i64
    }
}
