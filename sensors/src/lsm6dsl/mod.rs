//! ST LSM6DSL accelerometer and gyroscope (I2C address 0x6A, SA0 low; on the B-L475E-IOT01A on
//! I2C2 beside the HTS221): the accelerometer's samples through the part's FIFO with its own
//! timestamps, read in bursts on the FIFO's watermark (INT1). The gyroscope stays off.
//!
//! The configuration, fixed (datasheet DocID030071; ST's application note AN5040):
//! - ±16 g (0.488 mg a count), output data rate 1.66 kHz, high-performance mode;
//! - analog anti-aliasing filter at 1.5 kHz (BW0_XL = 0), digital LPF1 at ODR/2 (LPF1_BW_SEL = 0),
//!   LPF2 and the high-pass off: the chain's delay and low-pass belong to the instrument and the
//!   host states them as nuisance parameters of a check;
//! - the FIFO in continuous mode at 1.66 kHz, the accelerometer undecimated, the timestamp
//!   (25 µs a count, TIMER_HR) as the fourth data set every [`fifo::TIMESTAMP_EVERY`] samples,
//!   the watermark at [`WATERMARK_PATTERNS`] patterns on INT1.
//!
//! As the HTS221's driver, it borrows the bus for each call: a cancelled read must not take the
//! bus with it, and the bus is shared with the HTS221's poll.

pub mod fifo;

use embedded_hal_async::{delay::DelayNs, i2c::I2c};
use fifo::{FifoDecoder, FifoSample, PATTERN_WORDS, WORDS_PER_SET};

pub const ADDRESS: u8 = 0x6A;

pub const FIFO_CTRL1: u8 = 0x06;
pub const FIFO_CTRL2: u8 = 0x07;
pub const FIFO_CTRL3: u8 = 0x08;
pub const FIFO_CTRL4: u8 = 0x09;
pub const FIFO_CTRL5: u8 = 0x0A;
pub const INT1_CTRL: u8 = 0x0D;
pub const WHO_AM_I: u8 = 0x0F;
pub const WHO_AM_I_VALUE: u8 = 0x6A;
pub const CTRL1_XL: u8 = 0x10;
pub const CTRL3_C: u8 = 0x12;
pub const CTRL10_C: u8 = 0x19;
pub const FIFO_STATUS1: u8 = 0x3A;
pub const FIFO_DATA_OUT_L: u8 = 0x3E;
pub const TIMESTAMP2_REG: u8 = 0x42;
pub const WAKE_UP_DUR: u8 = 0x5C;

/// CTRL3_C: software reset (clears itself).
pub const CTRL3_C_SW_RESET: u8 = 1 << 0;
/// CTRL3_C: block data update and sub-address auto-increment (IF_INC). With IF_INC a burst from
/// FIFO_DATA_OUT_L rolls back to it after FIFO_DATA_OUT_H, so one read drains many words.
pub const CTRL3_C_BDU_IF_INC: u8 = 1 << 6 | 1 << 2;
/// CTRL1_XL: ODR 1.66 kHz (1000), ±16 g (FS_XL = 01), LPF1 at ODR/2, anti-aliasing at 1.5 kHz.
pub const CTRL1_XL_1660HZ_16G: u8 = 0b1000_0100;
/// WAKE_UP_DUR: TIMER_HR, the timestamp at 25 µs a count.
pub const WAKE_UP_DUR_TIMER_HR: u8 = 1 << 4;
/// CTRL10_C: TIMER_EN, the timestamp counter runs.
pub const CTRL10_C_TIMER_EN: u8 = 1 << 5;
/// FIFO_CTRL2: TIMER_PEDO_FIFO_EN, the timestamp goes into the FIFO (as its fourth data set).
pub const FIFO_CTRL2_TIMER_IN_FIFO: u8 = 1 << 7;
/// FIFO_CTRL3: gyroscope not in the FIFO, accelerometer undecimated.
pub const FIFO_CTRL3_XL_ONLY: u8 = 0b000_001;
/// FIFO_CTRL4: the fourth data set (the timestamp) decimated by 8 (DEC_DS4_FIFO = 101).
pub const FIFO_CTRL4_DS4_BY_8: u8 = 0b101 << 3;
/// FIFO_CTRL5: FIFO at 1.66 kHz (ODR_FIFO = 1000), continuous mode (110): full, it overwrites
/// the oldest words.
pub const FIFO_CTRL5_CONTINUOUS_1660HZ: u8 = 0b1000 << 3 | 0b110;
/// FIFO_CTRL5: bypass, which empties the FIFO.
pub const FIFO_CTRL5_BYPASS: u8 = 0;
/// INT1_CTRL: INT1_FTH, the FIFO watermark on INT1.
pub const INT1_CTRL_FTH: u8 = 1 << 3;
/// Written to TIMESTAMP2_REG, resets the timestamp counter.
pub const TIMESTAMP_RESET: u8 = 0xAA;

/// Patterns (of [`fifo::TIMESTAMP_EVERY`] samples) at the watermark: 64 samples, 38 ms at
/// 1.66 kHz; the FIFO's 2048 words hold 75 patterns, 360 ms, so a burst may wait for the bus.
pub const WATERMARK_PATTERNS: usize = 8;
/// The watermark in FIFO words.
pub const WATERMARK_WORDS: usize = WATERMARK_PATTERNS * PATTERN_WORDS;
/// Words the FIFO holds (4 KiB).
pub const FIFO_WORDS: usize = 2048;
/// Sensitivity at ±16 g [m/s² a count]: 0.488 mg (datasheet table 3) × standard gravity.
pub const MPS2_PER_COUNT: f32 = 0.488e-3 * 9.806_65;
/// One timestamp count [s] (TIMER_HR), on the part's own oscillator.
pub const TIMESTAMP_COUNT_S: f64 = 25e-6;

/// The software reset takes about 50 µs; polled every millisecond, at most this many times.
const RESET_POLLS: u32 = 5;
/// FIFO_STATUS2 bits.
const STATUS2_OVER_RUN: u8 = 1 << 6;
const STATUS2_DIFF_HIGH: u8 = 0b111;

#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    Bus,
    WrongDevice(u8),
    /// The software reset never cleared.
    ResetTimeout,
}

/// The part, set up: its FIFO's decoder (place in the pattern, the unwrapped timestamp).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Lsm6dsl {
    decoder: FifoDecoder,
}

/// What one burst read: samples written, and whether the FIFO overran since the last burst
/// (samples lost; the next stamped sample places the rest in time again).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Burst {
    pub samples: usize,
    pub overran: bool,
}

async fn write<I: I2c>(i2c: &mut I, register: u8, value: u8) -> Result<(), Error> {
    i2c.write(ADDRESS, &[register, value]).await.map_err(|_| Error::Bus)
}

/// Checks the part, resets it and sets it up as the module says, the timestamp counter reset
/// last so that the first stamp counts from the start of conversions.
pub async fn set_up<I: I2c>(i2c: &mut I, delay: &mut impl DelayNs) -> Result<Lsm6dsl, Error> {
    let mut id = [0u8];
    i2c.write_read(ADDRESS, &[WHO_AM_I], &mut id).await.map_err(|_| Error::Bus)?;
    if id[0] != WHO_AM_I_VALUE {
        return Err(Error::WrongDevice(id[0]));
    }
    write(i2c, CTRL3_C, CTRL3_C_SW_RESET).await?;
    let mut reset = false;
    for _ in 0..RESET_POLLS {
        delay.delay_ms(1).await;
        let mut ctrl3 = [0u8];
        i2c.write_read(ADDRESS, &[CTRL3_C], &mut ctrl3).await.map_err(|_| Error::Bus)?;
        if ctrl3[0] & CTRL3_C_SW_RESET == 0 {
            reset = true;
            break;
        }
    }
    if !reset {
        return Err(Error::ResetTimeout);
    }
    let [fth_low, fth_high] = (WATERMARK_WORDS as u16).to_le_bytes();
    for (register, value) in [
        (CTRL3_C, CTRL3_C_BDU_IF_INC),
        (FIFO_CTRL5, FIFO_CTRL5_BYPASS),
        (WAKE_UP_DUR, WAKE_UP_DUR_TIMER_HR),
        (CTRL10_C, CTRL10_C_TIMER_EN),
        (FIFO_CTRL1, fth_low),
        (FIFO_CTRL2, FIFO_CTRL2_TIMER_IN_FIFO | fth_high & 0b111),
        (FIFO_CTRL3, FIFO_CTRL3_XL_ONLY),
        (FIFO_CTRL4, FIFO_CTRL4_DS4_BY_8),
        (INT1_CTRL, INT1_CTRL_FTH),
        (CTRL1_XL, CTRL1_XL_1660HZ_16G),
        (TIMESTAMP2_REG, TIMESTAMP_RESET),
        (FIFO_CTRL5, FIFO_CTRL5_CONTINUOUS_1660HZ),
    ] {
        write(i2c, register, value).await?;
    }
    Ok(Lsm6dsl::default())
}

impl Lsm6dsl {
    /// Reads the FIFO's whole data sets, at most what `out` and `words` hold, into `out`: the
    /// status (words waiting, overrun, place in the pattern), then one burst of words. `words` is
    /// the caller's scratch (its length a multiple of 3; two bytes a word are read into it).
    pub async fn read_fifo<I: I2c>(&mut self, i2c: &mut I, words: &mut [u16], out: &mut [FifoSample]) -> Result<Burst, Error> {
        let mut status = [0u8; 4];
        i2c.write_read(ADDRESS, &[FIFO_STATUS1], &mut status).await.map_err(|_| Error::Bus)?;
        let overran = status[1] & STATUS2_OVER_RUN != 0;
        let waiting = match usize::from(u16::from_le_bytes([status[0], status[1] & STATUS2_DIFF_HIGH])) {
            // DIFF_FIFO has 11 bits: a FIFO full of its 2048 words, overrun, reads as none.
            0 if overran => FIFO_WORDS,
            n => n,
        };
        let pattern = usize::from(u16::from_le_bytes([status[2], status[3] & 0b11]));
        self.decoder.set_position(pattern);
        // A part-read data set (the FIFO overran mid-set) is skipped: its words are read and
        // dropped, so that decoding starts at a data set.
        let skip = (WORDS_PER_SET - pattern % WORDS_PER_SET) % WORDS_PER_SET;
        let whole_sets = waiting.saturating_sub(skip) / WORDS_PER_SET;
        let sets = sets_for(pattern + skip, whole_sets.min(words.len() / WORDS_PER_SET), out.len());
        let n_words = skip + sets * WORDS_PER_SET;
        if n_words == 0 {
            return Ok(Burst { samples: 0, overran });
        }
        let mut bytes = [0u8; 2 * BURST_WORDS];
        let mut read = 0;
        // Chunks of at most BURST_WORDS words: one I2C transfer each, the scratch on the stack
        // bounded however large the caller's buffers are.
        while read < n_words {
            let chunk = (n_words - read).min(BURST_WORDS);
            i2c.write_read(ADDRESS, &[FIFO_DATA_OUT_L], &mut bytes[..2 * chunk]).await.map_err(|_| Error::Bus)?;
            for (k, pair) in bytes[..2 * chunk].chunks_exact(2).enumerate() {
                if read + k >= skip {
                    words[read + k - skip] = u16::from_le_bytes([pair[0], pair[1]]);
                }
            }
            read += chunk;
        }
        self.decoder.set_position(pattern + skip);
        let samples = self.decoder.decode(&words[..sets * WORDS_PER_SET], out);
        Ok(Burst { samples, overran })
    }
}

/// Data sets, from the pattern's word `position` on and at most `available`, that hold at most
/// `capacity` samples: the burst stops before a sample that would not fit, leaving it in the
/// FIFO for the next, and never between a stamped sample and its timestamp.
fn sets_for(position: usize, available: usize, capacity: usize) -> usize {
    let mut samples = 0;
    let mut sets = 0;
    let mut at = position % PATTERN_WORDS;
    while sets < available {
        let is_sample = at != WORDS_PER_SET;
        if is_sample && samples == capacity {
            break;
        }
        samples += usize::from(is_sample);
        sets += 1;
        at = (at + WORDS_PER_SET) % PATTERN_WORDS;
    }
    if at == WORDS_PER_SET && sets > 0 {
        // The last set read would be the stamped sample without its stamp: left for the next burst.
        sets -= 1;
    }
    sets
}

/// Words read in one I2C transfer: one pattern of the watermark's eight.
const BURST_WORDS: usize = PATTERN_WORDS;
