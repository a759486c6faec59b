//! What the LSM6DSL's FIFO holds, decoded: words in a fixed pattern (accelerometer data sets,
//! every [`TIMESTAMP_EVERY`]-th followed by a timestamp data set), and the 24-bit timestamp
//! counter unwrapped into a count that does not wrap. Pure arithmetic, tested on the host.
//!
//! The pattern with the gyroscope off, the accelerometer undecimated and the timestamp as the
//! fourth data set decimated by [`TIMESTAMP_EVERY`] (datasheet DocID030071 §8 and AN5040 §9): at
//! each FIFO tick the part writes its enabled data sets in order, so one pattern is
//! `XL(ts) TS XL XL … XL`, [`TIMESTAMP_EVERY`] accelerometer data sets and one timestamp,
//! 3 words each. The timestamp data set is `TS[15:8] TS[23:16] | – TS[7:0] | steps` (low byte
//! first in each word) and stamps the accelerometer data set written at the same tick, the one
//! before it.

/// Accelerometer samples per timestamp in the FIFO (DEC_DS4_FIFO = 8): 6.75 bytes a sample on
/// the bus, 11.2 kB/s at 1.66 kHz, a quarter of what 400 kHz I2C carries.
pub const TIMESTAMP_EVERY: usize = 8;
/// Words in a data set (three axes, or the timestamp's three words).
pub const WORDS_PER_SET: usize = 3;
/// Words in one FIFO pattern.
pub const PATTERN_WORDS: usize = (TIMESTAMP_EVERY + 1) * WORDS_PER_SET;
/// The timestamp counter's width: it wraps every 2^24 counts (7 min at 25 µs a count).
pub const TIMESTAMP_BITS: u32 = 24;

/// One accelerometer sample from the FIFO: raw counts on the three axes, and the part's
/// timestamp (unwrapped, counts of its 25 µs timer) where the FIFO stamped it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FifoSample {
    pub xyz: [i16; 3],
    pub timestamp: Option<u64>,
}

/// The 24-bit timestamp counter made monotonic: each new value is taken as the smallest
/// forward step from the last one, so a wrap between two stamps (one every 8 samples, 4.8 ms
/// apart, against a wrap period of 7 minutes) is never missed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TimestampUnwrap {
    last: Option<u64>,
}

impl TimestampUnwrap {
    pub const fn new() -> Self {
        Self { last: None }
    }

    /// The unwrapped count of a raw 24-bit value.
    pub fn unwrap(&mut self, raw24: u32) -> u64 {
        let mask = (1u64 << TIMESTAMP_BITS) - 1;
        let raw = u64::from(raw24) & mask;
        let value = match self.last {
            None => raw,
            Some(last) => last + (raw.wrapping_sub(last) & mask),
        };
        self.last = Some(value);
        value
    }

    /// Forgets the last value: after the counter was reset (TIMESTAMP2_REG = 0xAA) or the part
    /// set up again.
    pub fn restart(&mut self) {
        self.last = None;
    }
}

/// The raw 24-bit timestamp of a timestamp data set's first two words, as the FIFO gives them
/// (each word little-endian): `TS[15:8] TS[23:16]`, then `– TS[7:0]`.
pub fn timestamp_of(words: [u16; 2]) -> u32 {
    let [ts_15_8, ts_23_16] = words[0].to_le_bytes();
    let [_, ts_7_0] = words[1].to_le_bytes();
    u32::from(ts_23_16) << 16 | u32::from(ts_15_8) << 8 | u32::from(ts_7_0)
}

/// Decodes FIFO words into samples, keeping its place in the pattern across bursts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FifoDecoder {
    /// Index in the pattern of the next word, as FIFO_PATTERN says.
    position: usize,
    unwrap: TimestampUnwrap,
}

impl FifoDecoder {
    pub const fn new() -> Self {
        Self { position: 0, unwrap: TimestampUnwrap::new() }
    }

    /// The word index within the pattern of the next word read, from FIFO_STATUS3/4; words
    /// before the next data set's start are not a whole data set and are skipped by the caller.
    pub fn position(&self) -> usize {
        self.position
    }

    /// Resynchronises with the part's FIFO_PATTERN (after an overrun the FIFO dropped its oldest
    /// words, wherever they were in the pattern).
    pub fn set_position(&mut self, pattern: usize) {
        self.position = pattern % PATTERN_WORDS;
    }

    pub fn restart(&mut self) {
        *self = Self::new();
    }

    /// Decodes whole data sets from `words` (its length a multiple of [`WORDS_PER_SET`], the
    /// first word at the decoder's position, which must be a data set's start) into `out`;
    /// returns how many samples it wrote. A timestamp stamps the sample written before it.
    pub fn decode(&mut self, words: &[u16], out: &mut [FifoSample]) -> usize {
        debug_assert_eq!(self.position % WORDS_PER_SET, 0);
        let mut n: usize = 0;
        for set in words.chunks_exact(WORDS_PER_SET) {
            let is_timestamp = self.position == WORDS_PER_SET;
            if is_timestamp {
                let ts = self.unwrap.unwrap(timestamp_of([set[0], set[1]]));
                if let Some(stamped) = n.checked_sub(1).and_then(|i| out.get_mut(i)) {
                    stamped.timestamp = Some(ts);
                }
            } else if let Some(slot) = out.get_mut(n) {
                *slot = FifoSample { xyz: [set[0] as i16, set[1] as i16, set[2] as i16], timestamp: None };
                n += 1;
            }
            self.position = (self.position + WORDS_PER_SET) % PATTERN_WORDS;
        }
        n
    }
}

#[cfg(test)]
mod tests {
    extern crate std;
    use std::{vec, vec::Vec};

    use super::*;

    #[test]
    fn the_counter_unwraps_across_its_24_bits() {
        let mut u = TimestampUnwrap::new();
        assert_eq!(u.unwrap(0xFF_FF00), 0xFF_FF00);
        assert_eq!(u.unwrap(0xFF_FFC0), 0xFF_FFC0);
        // Wrapped: 0x40 counts after 0xFF_FFC0 is 0x100_0000.
        assert_eq!(u.unwrap(0x00_0000), 0x100_0000);
        assert_eq!(u.unwrap(0x00_00C0), 0x100_00C0);
        u.restart();
        assert_eq!(u.unwrap(5), 5);
    }

    #[test]
    fn timestamp_bytes_are_in_the_fifo_order() {
        // TS = 0x12_3456: FIFO words [0x34 | 0x12 << 8], [xx | 0x56 << 8].
        assert_eq!(timestamp_of([0x1234, 0x5600]), 0x12_3456);
        assert_eq!(timestamp_of([0x1234, 0x56FF]), 0x12_3456, "the unused byte is ignored");
    }

    fn pattern(first: i16, ts: u32) -> Vec<u16> {
        let mut w = vec![first as u16, (first + 1) as u16, (first + 2) as u16];
        w.extend([((ts >> 8) & 0xFF | ((ts >> 16) & 0xFF) << 8) as u16, ((ts & 0xFF) << 8) as u16, 0]);
        for k in 1..TIMESTAMP_EVERY as i16 {
            let v = first + 10 * k;
            w.extend([v as u16, (v + 1) as u16, (v + 2) as u16]);
        }
        w
    }

    #[test]
    fn a_pattern_gives_its_samples_and_stamps_the_first() {
        let words = [pattern(100, 1000), pattern(-200, 1192)].concat();
        let mut d = FifoDecoder::new();
        let mut out = [FifoSample::default(); 2 * TIMESTAMP_EVERY];
        assert_eq!(d.decode(&words, &mut out), 2 * TIMESTAMP_EVERY);
        assert_eq!(out[0], FifoSample { xyz: [100, 101, 102], timestamp: Some(1000) });
        assert_eq!(out[1], FifoSample { xyz: [110, 111, 112], timestamp: None });
        assert_eq!(out[TIMESTAMP_EVERY], FifoSample { xyz: [-200, -199, -198], timestamp: Some(1192) });
        assert_eq!(d.position(), 0);
    }

    #[test]
    fn bursts_that_split_a_pattern_decode_as_one() {
        let words = [pattern(1, 50), pattern(7, 242)].concat();
        let mut whole = [FifoSample::default(); 16];
        FifoDecoder::new().decode(&words, &mut whole);
        let mut d = FifoDecoder::new();
        let mut parts = [FifoSample::default(); 16];
        let (a, b) = words.split_at(2 * WORDS_PER_SET);
        let n = d.decode(a, &mut parts);
        // The first burst ends just after the timestamp: its sample was stamped.
        assert_eq!(n, 1);
        assert_eq!(parts[0].timestamp, Some(50));
        let m = d.decode(b, &mut parts[n..]);
        assert_eq!(n + m, 16);
        assert_eq!(parts, whole);
    }

    #[test]
    fn a_burst_that_starts_at_a_timestamp_keeps_it_for_no_sample() {
        // After an overrun the FIFO may resume at the timestamp: its sample is gone, so no
        // sample is stamped wrongly.
        let words = pattern(1, 50);
        let mut d = FifoDecoder::new();
        d.set_position(WORDS_PER_SET);
        let mut out = [FifoSample::default(); 8];
        let n = d.decode(&words[WORDS_PER_SET..], &mut out);
        assert_eq!(n, TIMESTAMP_EVERY - 1);
        assert!(out[..n].iter().all(|s| s.timestamp.is_none()));
    }
}
