//! The map from a part's timestamp counter to the board's timer: `board = offset + rate · part`,
//! fitted by least squares over the recent pairs (part timestamp, board timer at the same
//! instant), each pair's weight falling by [`ClockMap::forget`] per pair, so that the rate
//! follows a temperature drift of either oscillator over minutes while the pairs' jitter averages
//! out. Neither oscillator's rate is taken from a datasheet: the part's is not bounded there
//! (ST advises deriving it from the timestamps), the board's is whatever its crystal gives.
//!
//! Computed in f64 on both sides from counts relative to the first pair: a pair a second, for
//! days, stays exact to far below a count.

use crate::numeric::forgetting_line::ForgettingLine;

/// The line through the pairs, relative to the first, with exponential forgetting.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockMap {
    origin: Option<(u64, u64)>,
    forget: f64,
    line: ForgettingLine<f64>,
    nominal_rate: f64,
}

impl ClockMap {
    /// `nominal_rate`: board counts per part count by the two datasheets, used until two pairs
    /// decide; `forget`: the weight kept per pair (e.g. 0.999: a memory of a thousand pairs).
    pub const fn new(nominal_rate: f64, forget: f64) -> Self {
        Self { origin: None, forget, line: ForgettingLine::empty(0.0), nominal_rate }
    }

    pub fn forget(&self) -> f64 {
        self.forget
    }

    /// Adds a pair: the part's unwrapped timestamp and the board's unwrapped timer at the same
    /// instant.
    pub fn push(&mut self, part: u64, board: u64) {
        let (p0, b0) = *self.origin.get_or_insert((part, board));
        let x = part as f64 - p0 as f64;
        let y = board as f64 - b0 as f64;
        self.line.push(x, y, self.forget);
    }

    /// Board counts per part count: the fitted slope, or the nominal before the pairs span time.
    pub fn rate(&self) -> f64 {
        let slope = if self.line.weight() >= 2.0 { self.line.slope() } else { None };
        slope.unwrap_or(self.nominal_rate)
    }

    /// The board's timer at a part's timestamp (fractional counts allowed), relative to nothing:
    /// in the board's counts. `None` before the first pair.
    pub fn board_of(&self, part: f64) -> Option<f64> {
        let (p0, b0) = self.origin?;
        let rate = self.rate();
        let (mx, my) = self.line.means();
        Some(b0 as f64 + my + rate * (part - p0 as f64 - mx))
    }

    /// The part's timestamp at a board time (fractional counts): the inverse of [`Self::board_of`].
    pub fn part_of(&self, board: f64) -> Option<f64> {
        let (p0, b0) = self.origin?;
        let rate = self.rate();
        let (mx, my) = self.line.means();
        Some(p0 as f64 + mx + (board - b0 as f64 - my) / rate)
    }
}

#[cfg(test)]
mod tests {
    use super::ClockMap;

    #[test]
    fn a_rate_and_offset_are_found_through_jitter() {
        // The part runs 80 ppm fast against the board's 80 MHz timer with 25 µs counts: 2000
        // board counts a part count nominally, here 2000 / (1 + 80e-6).
        let true_rate = 2000.0 / (1.0 + 80e-6);
        let mut map = ClockMap::new(2000.0, 0.999);
        let mut seed = 7u64;
        for k in 0..2000u64 {
            let part = 1_000_000 + 1536 * k;
            // ±2 µs of the interrupt's latency on the board's side.
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let jitter = ((seed >> 33) as f64 / (1u64 << 31) as f64 - 0.5) * 320.0;
            let board = (5e9 + true_rate * part as f64 + jitter) as u64;
            map.push(part, board);
        }
        assert!((map.rate() / true_rate - 1.0).abs() < 1e-6, "rate {}", map.rate());
        let part = 1_000_000.0 + 1536.0 * 1999.5;
        let board = map.board_of(part).unwrap();
        assert!((board - (5e9 + true_rate * part)).abs() < 40.0, "{board}");
        assert!((map.part_of(board).unwrap() - part).abs() < 1e-6);
    }

    #[test]
    fn before_two_pairs_the_nominal_rate_holds() {
        let mut map = ClockMap::new(2000.0, 0.999);
        assert_eq!(map.board_of(0.0), None);
        map.push(10, 1000);
        assert_eq!(map.rate(), 2000.0);
        assert_eq!(map.board_of(11.0), Some(3000.0));
    }
}
