//! The model table's 16-bit codes packed in about a byte each (row to row, the step's change from
//! bin to bin), and their decoding a few rows at a time.

use crate::humidity::spectrum::MAX_BINS;

/// A key row every this many rows of [`PackedCodes`]: a row away from the last decoded costs the
/// decoding of the rows since its key, 3.5 on average (a key row takes a byte a code more; the fit
/// took 4.1 million instructions with no [`Rows`] kept, 3.1 with).
pub const KEY_EVERY: usize = 8;
/// The byte of [`PackedCodes`] that stands for "the code follows whole".
const ESCAPE: u8 = 0x80;

/// The table's codes ([`fill_table`](super::fill_table)), row after row, in about half their 16
/// bits each: every [`KEY_EVERY`]-th row whole (two bytes a code, little-endian), every other row
/// as the step from the row before, bin by bin, each step told by its difference from the step at
/// the bin before in one signed byte, or [`ESCAPE`] and the code whole (two bytes) where that is
/// not within ±127. The model is smooth in humidity and frequency but for the resonance's peak, so
/// that difference fits a byte for 97 % of the codes. Why: the codes are the firmware's largest
/// item, 20 KB of flash whole and 12 KB packed.
#[derive(Clone, Copy, Debug)]
pub struct PackedCodes<'a> {
    pub bytes: &'a [u8],
    /// Where each key row starts in `bytes`.
    pub keys: &'a [u32],
}

/// Packs `codes` (rows of `bins`) into `bytes` ([`PackedCodes::bytes`]; 3 bytes a code is
/// always enough) and `keys` (one per [`KEY_EVERY`] rows, rounded up); returns the bytes used.
pub fn pack_codes(codes: &[u16], bins: usize, bytes: &mut [u8], keys: &mut [u32]) -> usize {
    let mut at = 0;
    let mut put = |at: &mut usize, b: &[u8]| {
        bytes[*at..*at + b.len()].copy_from_slice(b);
        *at += b.len();
    };
    for (i, row) in codes.chunks_exact(bins).enumerate() {
        if i % KEY_EVERY == 0 {
            keys[i / KEY_EVERY] = u32::try_from(at).expect("a table of fewer than 4 GB");
            for q in row {
                put(&mut at, &q.to_le_bytes());
            }
            continue;
        }
        let above = &codes[(i - 1) * bins..i * bins];
        let mut step = 0i32;
        for (&q, &up) in row.iter().zip(above) {
            let next = i32::from(q) - i32::from(up);
            match i8::try_from(next - step) {
                Ok(d) if d as u8 != ESCAPE => put(&mut at, &[d as u8]),
                _ => {
                    let [lo, hi] = q.to_le_bytes();
                    put(&mut at, &[ESCAPE, lo, hi]);
                }
            }
            step = next;
        }
    }
    at
}

/// The rows of a [`PackedCodes`] last decoded, up to four: a fit reads the table node after node,
/// then again and again about its best, and so decodes each row it reads about once.
#[derive(Clone)]
pub(super) struct Rows {
    /// Rows `from..next` are in `ring`, row r at `r % 4`; `at` is where row `next` starts.
    from: usize,
    next: usize,
    at: usize,
    ring: [[u16; MAX_BINS]; 4],
}

impl Rows {
    pub(super) fn new() -> Self {
        Rows { from: 0, next: 0, at: 0, ring: [[0; MAX_BINS]; 4] }
    }

    /// Row `r`, once [`PackedCodes::decode`] has made it.
    pub(super) fn row(&self, r: usize) -> &[u16; MAX_BINS] {
        &self.ring[r % 4]
    }
}

impl PackedCodes<'_> {
    /// Rows `lo..=hi` (at most four) of `bins` codes each into `rows`: on from the last row
    /// decoded where that is the shorter way, else from the key row at or before `lo`.
    pub(super) fn decode(&self, bins: usize, lo: usize, hi: usize, rows: &mut Rows) {
        let key = lo / KEY_EVERY * KEY_EVERY;
        if !(rows.from <= lo && rows.next > key) {
            (rows.from, rows.next, rows.at) = (key, key, self.keys[lo / KEY_EVERY] as usize);
        }
        let b = self.bytes;
        let mut at = rows.at;
        for r in rows.next..=hi {
            if r % KEY_EVERY == 0 {
                for q in rows.ring[r % 4][..bins].iter_mut() {
                    *q = u16::from_le_bytes([b[at], b[at + 1]]);
                    at += 2;
                }
            } else {
                rows.ring[r % 4] = rows.ring[(r - 1) % 4];
                let mut step = 0i32;
                for q in rows.ring[r % 4][..bins].iter_mut() {
                    let d = b[at];
                    at += 1;
                    let up = i32::from(*q);
                    if d == ESCAPE {
                        *q = u16::from_le_bytes([b[at], b[at + 1]]);
                        at += 2;
                        step = i32::from(*q) - up;
                    } else {
                        step += i32::from(d as i8);
                        *q = (up + step) as u16;
                    }
                }
            }
            rows.next = r + 1;
            rows.from = rows.from.max(rows.next.saturating_sub(4));
        }
        rows.at = at;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::calibration::laws::Calibration;
    use crate::humidity::spectrum::BinGeometry;
    use crate::humidity::strip::table::{fill_table, table_nodes};
    use crate::humidity::strip::test_support::Lcg;
    use std::vec;
    use std::vec::Vec;

    #[test]
    fn packed_codes_are_the_codes() {
        // The default calibration's table, and one of codes far apart (nearly all escaped), in
        // rows of the most bins: every row alike from its key row, alone or with those after it.
        let c = Calibration::default_preset();
        let g = BinGeometry::new(2000.0, &crate::band::Band::DEFAULT);
        let nodes = table_nodes(&c);
        let (mut smooth, mut sd_cal) = (vec![0u16; nodes * g.bins], vec![0.0f64; nodes]);
        fill_table(&c, &g, &mut smooth, &mut sd_cal);
        let mut rng = Lcg(3);
        let rough: Vec<u16> = (0..20 * MAX_BINS).map(|_| (rng.next() * 65536.0) as u16).collect();
        for (codes, bins) in [(&smooth, g.bins), (&rough, MAX_BINS)] {
            let rows = codes.len() / bins;
            let (mut bytes, mut keys) = (vec![0u8; 3 * codes.len()], vec![0u32; rows.div_ceil(KEY_EVERY)]);
            let used = pack_codes(codes, bins, &mut bytes, &mut keys);
            let packed = PackedCodes { bytes: &bytes[..used], keys: &keys };
            // Each span of up to four rows from scratch, and from whatever the span before left.
            let mut after = Rows::new();
            for (lo, span) in (0..rows).flat_map(|lo| (1..=4.min(rows - lo)).map(move |n| (lo, n))).chain([(3, 2), (0, 4), (17, 3), (9, 1)])
            {
                let mut fresh = Rows::new();
                for r in [&mut fresh, &mut after] {
                    packed.decode(bins, lo, lo + span - 1, r);
                    for row in lo..lo + span {
                        assert_eq!(&r.row(row)[..bins], &codes[row * bins..(row + 1) * bins], "row {row}");
                    }
                }
            }
        }
        let (mut bytes, mut keys) = (vec![0u8; 3 * smooth.len()], vec![0u32; nodes.div_ceil(KEY_EVERY)]);
        let used = pack_codes(&smooth, g.bins, &mut bytes, &mut keys);
        assert!(used < smooth.len() * 2 * 2 / 3, "{used} bytes for {} codes", smooth.len());
    }
}
