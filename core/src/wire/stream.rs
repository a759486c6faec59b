//! Wire format of the firmware's binary stream, encoder and decoder in one place, so the
//! firmware (encodes), `cargo xtask qemu` and `cargo ipmc monitor` (decode) cannot drift apart.
//! No heap: the encoder writes into a caller's buffer, the decoder works in place.
//!
//! One frame per block of estimates:
//!
//! ```text
//! payload, little endian:
//!   u8   version (= FRAME_VERSION)
//!   u32  index of the block's first sample since acquisition start
//!   f32  RH [%] the block's active design is for
//!   f32  RH [%] of the strip at the block: the reading through the calibration's humidity path
//!        (sensor correction, hydration lag), before clamping to the calibrated range
//!   f32  RH [%] as the humidity sensor read it
//!   f32  expected relative rms error of the block's estimates in the band, 1σ (a fraction;
//!        `ipmc_core::inverse::expected_error`)
//!   f32  1σ of the reading through the humidity path [%RH] (`ipmc_core::humidity::hygrometer`)
//!   f32  RH [%] of the strip from its own current, its last fit (NaN: none), and its 1σ
//!   f32
//!   u8   why the strip's own estimate is missing: 0 it is there, else the refusal's code
//!        (`ipmc_core::humidity::strip::Refusal::code`), 255 before the first fit
//!   f32  RH [%] of the reading and the strip's estimate fused, and its 1σ
//!   f32
//!   u16  flags (bits: [`flags`])
//!   u8   the band's shape (`ipmc_core::band::Shape::code`: 0 linear phase, 1 low latency)  } version 5
//!   u16  the estimates' delay behind the base motion [samples]: the design's preview and the } on; a
//!        band's pure delay (a low-latency band's own delay is in its phase, not here)       } version 4
//!   u8   the humidity the designs follow (`HumidityMode::code`: 0 reading, 1 fused)        } frame has none
//!   u8   the board's accelerometer: 1 a check's samples follow the estimates, 0 none (no   } version 6
//!        part, or it does not answer)                                                        } on
//!   u8   n, number of estimates (the firmware's BLOCK_LEN, 32)
//!   f32  × n  base displacement estimates [m], one per sample at the firmware's sample rate
//! only where the accelerometer's byte is 1, a check's n samples (an earlier block's: the part's
//! samples reach the board later than the ADC's, `ipmc_core::resample::track`):
//!   u32  index of their first sample
//!   f32  × n  the strip's current [A], as the ADC gave it
//!   f32  × n  the accelerometer at the same instants [m/s²], along the strip's bending axis,
//!             resampled onto the ADC's clock (NaN where the resampler had no whole block)
//!   u32  the estimate's error measured against the accelerometer: its latest window's end, } version 7
//!        in the running error's count of samples (u32::MAX: no window measured yet),       } on
//!   f32  the error measured in it, a fraction of the reference's rms in band, and          }
//!   f32  the error the blocks stated for it (1σ, a fraction)                              }
//!        (`ipmc_core::firmware::running_error`)
//!   u16  CRC-16/IBM-3740 (poly 0x1021, init 0xFFFF) of all bytes above
//! frame = COBS(payload) followed by one 0x00 delimiter
//! ```
//!
//! COBS leaves no 0x00 inside a frame, so a reader that starts mid-stream or loses bytes
//! resynchronises at the next delimiter; the CRC catches what COBS cannot (flipped bits).

use core::fmt;

use crc::{CRC_16_IBM_3740, Crc};

/// Status bits of a frame's `flags`, raised by the firmware (`src/contract/flags.rs` re-exports
/// them). The bit positions are part of the wire format: append, never renumber.
pub mod flags {
    /// At least one current sample of the block was at or near an ADC rail.
    pub const CLIPPED: u16 = 1 << 0;
    /// The last humidity reading failed or was implausible; RH is the last good value.
    pub const RH_STALE: u16 = 1 << 1;
    /// RH was outside the calibration's range and was clamped to it.
    pub const RH_CLAMPED: u16 = 1 << 2;
    /// A new filter design took effect at the start of this block.
    pub const RETUNED: u16 = 1 << 3;
    /// Samples were lost before this block (ADC/DMA overrun or replay gap).
    pub const SAMPLES_LOST: u16 = 1 << 4;
    /// Earlier blocks were not reported (the report queue was full, or the stream could not
    /// take their frames in time).
    pub const REPORT_DROPPED: u16 = 1 << 5;
    /// The last requested retune failed; the previous design stays active.
    pub const DESIGN_FAILED: u16 = 1 << 6;
    /// A current sample was not a measurement (not finite, or beyond the compensator's input
    /// limit); it was replaced by 0 A.
    pub const BAD_SAMPLE: u16 = 1 << 7;
    /// The current input has repeated one value for a second or more (a hung ADC or DMA, an
    /// amplifier stuck at a rail): the estimates are not of a live signal. Clears at the first
    /// changing sample.
    pub const STUCK: u16 = 1 << 8;
    /// The active design is at the firmware's start-up fallback humidity (clamped into the
    /// calibrated range): no humidity reading had arrived when sampling started. Clears when a
    /// design at a reading takes over.
    pub const RH_FALLBACK: u16 = 1 << 9;
    /// The sample clock is not locked to the board's 32.768 kHz crystal: the crystal did not
    /// start (the firmware runs from HSI16, ±1 % over temperature) or stopped while running
    /// (its clock security system tripped; MSI runs free). The sample rate, and with it every
    /// designed frequency and time stamp, is off by up to that much. Stays until reset.
    pub const CLOCK_FAULT: u16 = 1 << 10;
    /// The strip's own humidity estimate is missing: its last fit refused (the frame says why)
    /// or none has finished yet. The fused humidity is the reading's.
    pub const OWN_REFUSED: u16 = 1 << 11;
    /// The spectrum as it stood after this block's current went to the fit.
    pub const FIT_STARTED: u16 = 1 << 12;
    /// The fit's result was taken at this block, before its current went into the spectrum.
    pub const FIT_DONE: u16 = 1 << 13;
    /// The ADC overran (a conversion finished before the DMA had taken the one before), which
    /// stops its DMA requests: the firmware restarted the conversions. `SAMPLES_LOST` says how
    /// many samples the stop cost (to within one sample: after a restart the ring's positions no
    /// longer count samples, the board's clock does).
    pub const ADC_OVERRUN: u16 = 1 << 14;
    /// The estimate's error measured against the board's accelerometer exceeds the stated one
    /// beyond chance (`ipmc_core::firmware::calibration_stale`, p < 0.01 over the recent windows).
    /// Raised on every block from the window whose test called it until the next window, while
    /// checks come (the window's figures ride in the check's part of the frame, version 7).
    pub const CALIBRATION_STALE: u16 = 1 << 15;

    /// Every bit with its name, lowest first (for host displays).
    pub const NAMES: [(u16, &str); 16] = [
        (CLIPPED, "CLIPPED"),
        (RH_STALE, "RH_STALE"),
        (RH_CLAMPED, "RH_CLAMPED"),
        (RETUNED, "RETUNED"),
        (SAMPLES_LOST, "SAMPLES_LOST"),
        (REPORT_DROPPED, "REPORT_DROPPED"),
        (DESIGN_FAILED, "DESIGN_FAILED"),
        (BAD_SAMPLE, "BAD_SAMPLE"),
        (STUCK, "STUCK"),
        (RH_FALLBACK, "RH_FALLBACK"),
        (CLOCK_FAULT, "CLOCK_FAULT"),
        (OWN_REFUSED, "OWN_REFUSED"),
        (FIT_STARTED, "FIT_STARTED"),
        (FIT_DONE, "FIT_DONE"),
        (ADC_OVERRUN, "ADC_OVERRUN"),
        (CALIBRATION_STALE, "CALIBRATION_STALE"),
    ];
}

/// Bumped whenever the payload layout changes. 2: the strip's humidity and the reading beside
/// the design's (version 1 had one RH, the reading's). 3: the expected error after the
/// humidities. 4: the strip's own hygrometer (the reading's 1σ, the strip's estimate and the
/// fused humidity with theirs). 5: what the firmware runs ([`Setup`]): the band's shape, the
/// estimates' delay, the humidity mode. 6: a check (`Check`) beside the estimates when the
/// board's accelerometer answers: the current and the accelerometer resampled onto the ADC's
/// clock, what a check recording holds (`current_a`, `accel_mps2`). 7: beside a check, the
/// estimate's error the device measured against it ([`ErrorWindow`]).
pub const FRAME_VERSION: u8 = 7;
/// The version before the running error: its checks have no window.
const VERSION_BEFORE_WINDOW: u8 = 6;
/// The version before the accelerometer: the decoder reads it as a frame without one.
const VERSION_BEFORE_ACCEL: u8 = 5;
/// The oldest version the decoder still reads (its frames have no [`Setup`]).
pub const OLDEST_VERSION: u8 = 4;
/// version + first sample + RH of the design, of the strip, as read + expected error +
/// the hygrometer's + flags + the setup + the accelerometer's byte + count.
pub const HEADER_LEN: usize = 1 + 4 + 4 * 4 + HYGROMETER_LEN + 2 + SETUP_LEN + ACCEL_LEN + 1;
const HYGROMETER_LEN: usize = 5 * 4 + 1;
const SETUP_LEN: usize = 1 + 2 + 1;
const ACCEL_LEN: usize = 1;
const CRC_LEN: usize = 2;
/// The count is one byte.
pub const MAX_ESTIMATES: usize = u8::MAX as usize;

const CRC16: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

/// Payload bytes of a frame carrying `n` estimates, and a check's `n` samples when `check`.
pub const fn payload_len(n: usize, check: bool) -> usize {
    HEADER_LEN + 4 * n + if check { 4 + 8 * n + WINDOW_LEN } else { 0 } + CRC_LEN
}

/// A check's window: its end, the error measured and the error stated.
const WINDOW_LEN: usize = 3 * 4;

/// Encoded frame length for `n` estimates in the worst case (a check's frame),
/// delimiter included: the size of an encoder's output buffer.
pub const fn max_frame_len(n: usize) -> usize {
    cobs::max_encoding_length(payload_len(n, true)) + 1
}

/// Largest encoded frame any valid stream can contain, delimiter included: the size of a
/// decoder's buffer that accepts every frame size.
pub const MAX_FRAME_LEN: usize = max_frame_len(MAX_ESTIMATES);

/// Everything in a frame except the estimates.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Header {
    /// Index of the block's first sample since acquisition start (wraps at 2³²).
    pub first_sample: u32,
    /// The humidity the block's active design is for [%].
    pub rh_pct: f32,
    /// The strip's humidity at the block [%] (NaN before the first reading).
    pub rh_strip_pct: f32,
    /// The humidity sensor's reading [%] (NaN before the first).
    pub rh_read_pct: f32,
    /// The estimates' expected relative rms error in the band, 1σ (a fraction).
    pub rel_err: f32,
    pub hygrometer: Hygrometer,
    pub flags: u16,
    /// What the firmware runs; none in a version 4 frame.
    pub setup: Option<Setup>,
}

/// What the firmware runs, as its calibration set it up: what a reader needs to line the
/// estimates up with the base motion and to know what they mean.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Setup {
    /// `ipmc_core::band::Shape::code`.
    pub band_shape: u8,
    /// The estimates' delay behind the base motion [samples at the firmware's rate].
    pub delay_samples: u16,
    /// `ipmc_core::calibration::humidity_path::HumidityMode::code`.
    pub humidity_mode: u8,
}

/// The strip's own hygrometer at the block [%RH].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Hygrometer {
    /// 1σ of the reading through the humidity path (`Header::rh_strip_pct`).
    pub read_sd_pct: f32,
    /// The strip's humidity from its own current, and its 1σ (NaN: no estimate).
    pub own_pct: f32,
    pub own_sd_pct: f32,
    /// 0: there is an estimate; else why not (`Refusal::code`); [`Hygrometer::NO_FIT_YET`].
    pub own_refusal: u8,
    /// The design humidity of a `fused` calibration, and its 1σ.
    pub fused_pct: f32,
    pub fused_sd_pct: f32,
}

impl Hygrometer {
    pub const NO_FIT_YET: u8 = u8::MAX;
    /// Before the first reading.
    pub const NONE: Hygrometer = Hygrometer {
        read_sd_pct: f32::NAN,
        own_pct: f32::NAN,
        own_sd_pct: f32::NAN,
        own_refusal: Self::NO_FIT_YET,
        fused_pct: f32::NAN,
        fused_sd_pct: f32::NAN,
    };
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// More than [`MAX_ESTIMATES`] estimates.
    TooManyEstimates(usize),
    /// The output buffer is shorter than [`max_frame_len`] of the estimate count.
    BufferTooSmall,
    /// A check whose samples are not one per estimate, or in a frame without a setup (the
    /// version 4 layout, which has no place for it).
    Check,
}

/// A check's samples of a block, one per estimate: what a check recording holds beside the time
/// and the humidity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Check<'a> {
    /// Index of the first sample (an earlier block's than the frame's estimates).
    pub first_sample: u32,
    /// The strip's current [A], as the ADC gave it.
    pub current_a: &'a [f32],
    /// The board's accelerometer at the same instants [m/s²].
    pub accel_mps2: &'a [f32],
    /// The estimate's error the device measured against the accelerometer, its latest window
    /// (None: none measured yet).
    pub window: Option<ErrorWindow>,
}

/// A window of the estimate's error measured against the board's accelerometer
/// (`ipmc_core::firmware::running_error::Window`), as the stream carries it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ErrorWindow {
    /// The window's end, in the running error's count of samples (wraps at 2³²).
    pub end_sample: u32,
    /// The error measured in it, a fraction of the reference's rms in band.
    pub measured: f32,
    /// The error the blocks stated for it (their rms, 1σ, a fraction).
    pub stated: f32,
}

impl ErrorWindow {
    /// The end that says no window has been measured yet.
    pub const NONE_END: u32 = u32::MAX;
}

/// Encodes one frame into `out`: the header, the estimates and, where the board's accelerometer
/// answers, the block's `check`; returns its length including the 0x00 delimiter.
pub fn encode(header: &Header, estimates: &[f32], check: Option<Check<'_>>, out: &mut [u8]) -> Result<usize, EncodeError> {
    let count = u8::try_from(estimates.len()).map_err(|_| EncodeError::TooManyEstimates(estimates.len()))?;
    if out.len() < max_frame_len(estimates.len()) {
        return Err(EncodeError::BufferTooSmall);
    }
    let n = estimates.len();
    if check.is_some_and(|c| c.current_a.len() != n || c.accel_mps2.len() != n || header.setup.is_none()) {
        return Err(EncodeError::Check);
    }
    let (body, _) = out.split_at_mut(out.len() - 1);
    // Streamed straight into the output (no payload copy): the CRC and COBS see the same bytes.
    let mut encoder = cobs::CobsEncoder::new(body);
    let mut digest = CRC16.digest();
    let mut put = |bytes: &[u8]| -> Result<(), EncodeError> {
        digest.update(bytes);
        encoder.push(bytes).map_err(|_| EncodeError::BufferTooSmall)
    };
    // The header laid out first and put at once (a put is the CRC's and COBS's code, in line
    // once per call on the device). Without a setup, the version 4 layout: what a firmware of
    // that release sent.
    let mut head = [0u8; HEADER_LEN];
    let mut at = 0;
    let mut field = |bytes: &[u8]| {
        if let Some(to) = head.get_mut(at..at + bytes.len()) {
            to.copy_from_slice(bytes);
        }
        at += bytes.len();
    };
    field(&[if header.setup.is_some() { FRAME_VERSION } else { OLDEST_VERSION }]);
    field(&header.first_sample.to_le_bytes());
    field(&header.rh_pct.to_le_bytes());
    field(&header.rh_strip_pct.to_le_bytes());
    field(&header.rh_read_pct.to_le_bytes());
    field(&header.rel_err.to_le_bytes());
    let h = &header.hygrometer;
    field(&h.read_sd_pct.to_le_bytes());
    field(&h.own_pct.to_le_bytes());
    field(&h.own_sd_pct.to_le_bytes());
    field(&[h.own_refusal]);
    field(&h.fused_pct.to_le_bytes());
    field(&h.fused_sd_pct.to_le_bytes());
    field(&header.flags.to_le_bytes());
    if let Some(setup) = header.setup {
        field(&[setup.band_shape]);
        field(&setup.delay_samples.to_le_bytes());
        field(&[setup.humidity_mode]);
        field(&[u8::from(check.is_some())]);
    }
    field(&[count]);
    put(head.get(..at).unwrap_or(&head))?;
    for v in estimates {
        put(&v.to_le_bytes())?;
    }
    if let Some(c) = check {
        put(&c.first_sample.to_le_bytes())?;
        for v in c.current_a.iter().chain(c.accel_mps2) {
            put(&v.to_le_bytes())?;
        }
        let w = c.window.unwrap_or(ErrorWindow { end_sample: ErrorWindow::NONE_END, measured: f32::NAN, stated: f32::NAN });
        let mut window = [0u8; WINDOW_LEN];
        for (to, word) in window.chunks_exact_mut(4).zip([w.end_sample.to_le_bytes(), w.measured.to_le_bytes(), w.stated.to_le_bytes()]) {
            to.copy_from_slice(&word);
        }
        put(&window)?;
    }
    let crc = digest.finalize();
    encoder.push(&crc.to_le_bytes()).map_err(|_| EncodeError::BufferTooSmall)?;
    let n = encoder.finalize();
    // The length check above leaves room for the delimiter after the worst-case encoding.
    *out.get_mut(n).ok_or(EncodeError::BufferTooSmall)? = 0;
    Ok(n + 1)
}

/// Why a frame was rejected. Every case means "skip this frame"; the stream goes on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// Not valid COBS (typically a frame whose start was lost).
    Cobs,
    /// Fewer bytes than a header and a CRC.
    TooShort(usize),
    /// The CRC does not match: some byte changed on the way.
    Crc,
    /// A frame of another format version.
    Version(u8),
    /// The count byte disagrees with the frame's length.
    Length { count: u8, payload_len: usize },
    /// The accelerometer's byte is neither 0 nor 1.
    CheckMarker(u8),
    /// More bytes than any frame has before a delimiter (the [`Deframer`] buffer overflowed).
    TooLong,
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::Cobs => write!(f, "not a valid COBS frame"),
            DecodeError::TooShort(n) => write!(f, "frame of {n} bytes is too short"),
            DecodeError::Crc => write!(f, "CRC mismatch"),
            DecodeError::Version(v) => write!(
                f,
                "frame version {v}, this decoder reads versions {OLDEST_VERSION}–{FRAME_VERSION}: the firmware and the \
                 host tool are from different releases (build and flash both from one checkout)"
            ),
            DecodeError::Length { count, payload_len } => {
                write!(f, "frame says {count} estimates but its payload has {payload_len} bytes")
            }
            DecodeError::CheckMarker(b) => {
                write!(f, "the accelerometer's byte is {b}, neither 0 (no check) nor 1 (a check's samples follow)")
            }
            DecodeError::TooLong => write!(f, "no delimiter within {MAX_FRAME_LEN} bytes"),
        }
    }
}

/// A decoded frame, borrowing the estimates from the decoder's buffer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame<'a> {
    pub header: Header,
    /// The estimates' bytes, 4 per estimate (read with [`Frame::estimates`]).
    estimate_bytes: &'a [[u8; 4]],
    /// A check's first sample, current and accelerations, as many each as estimates (read with
    /// [`Frame::check_first_sample`], [`Frame::currents`] and [`Frame::accelerations`]); None:
    /// the frame has none.
    check_bytes: Option<CheckBytes<'a>>,
}

/// A check's part of a frame, as the decoder found it.
#[derive(Debug, Clone, Copy, PartialEq)]
struct CheckBytes<'a> {
    first_sample: u32,
    current: &'a [[u8; 4]],
    accel: &'a [[u8; 4]],
    window: Option<ErrorWindow>,
}

impl<'a> Frame<'a> {
    /// Base displacement estimates [m], in sample order.
    pub fn estimates(&self) -> impl ExactSizeIterator<Item = f32> + 'a {
        self.estimate_bytes.iter().map(|b| f32::from_le_bytes(*b))
    }
    /// A check's current at each estimate's sample [A], in sample order; None where the board's
    /// accelerometer did not answer, or in a frame of a version before it.
    pub fn currents(&self) -> Option<impl ExactSizeIterator<Item = f32> + 'a> {
        self.check_bytes.map(|c| c.current.iter().map(|b| f32::from_le_bytes(*b)))
    }
    /// The board's accelerometer at each estimate's sample [m/s²], as [`Frame::currents`].
    pub fn accelerations(&self) -> Option<impl ExactSizeIterator<Item = f32> + 'a> {
        self.check_bytes.map(|c| c.accel.iter().map(|b| f32::from_le_bytes(*b)))
    }
    /// Index of a check's first sample (the samples of [`Frame::currents`]).
    pub fn check_first_sample(&self) -> Option<u32> {
        self.check_bytes.map(|c| c.first_sample)
    }
    /// The error the device measured against a check, its latest window; None without a check,
    /// before the first window, or in a frame of a version before it.
    pub fn error_window(&self) -> Option<ErrorWindow> {
        self.check_bytes.and_then(|c| c.window)
    }
    pub fn len(&self) -> usize {
        self.estimate_bytes.len()
    }
    pub fn is_empty(&self) -> bool {
        self.estimate_bytes.is_empty()
    }
}

/// Decodes one frame: the bytes between two delimiters (without them), decoded in place.
pub fn decode(encoded: &mut [u8]) -> Result<Frame<'_>, DecodeError> {
    let n = cobs::decode_in_place(encoded).map_err(|_| DecodeError::Cobs)?;
    let payload = encoded.get(..n).ok_or(DecodeError::Cobs)?;
    let (body, crc) = payload.split_last_chunk::<CRC_LEN>().ok_or(DecodeError::TooShort(n))?;
    // A frame of another version may be shorter than this one's header: its version is the
    // error worth reporting, so the length is checked field by field after it.
    if body.is_empty() {
        return Err(DecodeError::TooShort(n));
    }
    if CRC16.checksum(body) != u16::from_le_bytes(*crc) {
        return Err(DecodeError::Crc);
    }
    let (&[version], rest) = body.split_first_chunk::<1>().ok_or(DecodeError::TooShort(n))?;
    if !(OLDEST_VERSION..=FRAME_VERSION).contains(&version) {
        return Err(DecodeError::Version(version));
    }
    let (first_sample, rest) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
    let (rh_pct, rest) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
    let (rh_strip_pct, rest) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
    let (rh_read_pct, rest) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
    let (rel_err, rest) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
    let f32_field = |rest: &mut &[u8]| -> Result<f32, DecodeError> {
        let (v, r) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
        *rest = r;
        Ok(f32::from_le_bytes(*v))
    };
    let mut rest = rest;
    let read_sd_pct = f32_field(&mut rest)?;
    let own_pct = f32_field(&mut rest)?;
    let own_sd_pct = f32_field(&mut rest)?;
    let (&[own_refusal], r) = rest.split_first_chunk::<1>().ok_or(DecodeError::TooShort(n))?;
    rest = r;
    let fused_pct = f32_field(&mut rest)?;
    let fused_sd_pct = f32_field(&mut rest)?;
    let hygrometer = Hygrometer { read_sd_pct, own_pct, own_sd_pct, own_refusal, fused_pct, fused_sd_pct };
    let (flags, mut rest) = rest.split_first_chunk::<2>().ok_or(DecodeError::TooShort(n))?;
    let setup = if version >= VERSION_BEFORE_ACCEL {
        let (&[band_shape, d0, d1, humidity_mode], r) = rest.split_first_chunk::<4>().ok_or(DecodeError::TooShort(n))?;
        rest = r;
        Some(Setup { band_shape, delay_samples: u16::from_le_bytes([d0, d1]), humidity_mode })
    } else {
        None
    };
    let check = if version > VERSION_BEFORE_ACCEL {
        let (&[marker], r) = rest.split_first_chunk::<1>().ok_or(DecodeError::TooShort(n))?;
        rest = r;
        match marker {
            0 => false,
            1 => true,
            b => return Err(DecodeError::CheckMarker(b)),
        }
    } else {
        false
    };
    let (&[count], rest) = rest.split_first_chunk::<1>().ok_or(DecodeError::TooShort(n))?;
    let (values, tail) = rest.as_chunks::<4>();
    // A check's first sample is one word more, and from version 7 its window three.
    let window_words = if version > VERSION_BEFORE_WINDOW { WINDOW_LEN / 4 } else { 0 };
    let words = count as usize + if check { 1 + 2 * count as usize + window_words } else { 0 };
    if values.len() != words || !tail.is_empty() {
        return Err(DecodeError::Length { count, payload_len: n });
    }
    let (estimate_bytes, check_bytes) = values.split_at(count as usize);
    let check_bytes = check_bytes.split_first().map(|(first, samples)| {
        let (current, rest) = samples.split_at(count as usize);
        let (accel, window) = rest.split_at(count as usize);
        let window = match window {
            [end, measured, stated] if u32::from_le_bytes(*end) != ErrorWindow::NONE_END => Some(ErrorWindow {
                end_sample: u32::from_le_bytes(*end),
                measured: f32::from_le_bytes(*measured),
                stated: f32::from_le_bytes(*stated),
            }),
            _ => None,
        };
        CheckBytes { first_sample: u32::from_le_bytes(*first), current, accel, window }
    });
    Ok(Frame {
        header: Header {
            first_sample: u32::from_le_bytes(*first_sample),
            rh_pct: f32::from_le_bytes(*rh_pct),
            rh_strip_pct: f32::from_le_bytes(*rh_strip_pct),
            rh_read_pct: f32::from_le_bytes(*rh_read_pct),
            rel_err: f32::from_le_bytes(*rel_err),
            hygrometer,
            flags: u16::from_le_bytes(*flags),
            setup,
        },
        estimate_bytes,
        check_bytes,
    })
}

/// Splits a byte stream at the 0x00 delimiters and decodes each frame, one byte at a time,
/// in a fixed buffer of `N` bytes (use [`MAX_FRAME_LEN`] to accept every valid frame).
/// Bytes before the first delimiter of a stream joined mid-frame come out as one failed frame.
pub struct Deframer<const N: usize> {
    buf: [u8; N],
    len: usize,
    overflowed: bool,
}

impl<const N: usize> Default for Deframer<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Deframer<N> {
    pub const fn new() -> Self {
        Self { buf: [0; N], len: 0, overflowed: false }
    }

    /// Feeds one byte; at a delimiter that ends a non-empty frame, returns that frame decoded
    /// (or why it was rejected). Empty frames (repeated delimiters) are ignored.
    pub fn push(&mut self, byte: u8) -> Option<Result<Frame<'_>, DecodeError>> {
        if byte != 0 {
            match self.buf.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                }
                None => self.overflowed = true,
            }
            return None;
        }
        let len = core::mem::replace(&mut self.len, 0);
        if core::mem::replace(&mut self.overflowed, false) {
            return Some(Err(DecodeError::TooLong));
        }
        if len == 0 {
            return None;
        }
        Some(self.buf.get_mut(..len).map_or(Err(DecodeError::TooLong), decode))
    }
}

#[cfg(test)]
mod tests;
