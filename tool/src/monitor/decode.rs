//! The firmware's binary stream decoded into samples and status lines, with ipmc-core's
//! `wire::stream` codec (the one the firmware encodes with), independent of where the bytes come
//! from. A frame that does not decode (garbage, joined mid-frame, flipped bits) is skipped and
//! counted; the stream goes on at the next delimiter.

use crate::scoring::stale_chance::undecided;
use ipmc_core::band::Shape;
use ipmc_core::firmware::calibration_stale::StaleTest;
use ipmc_core::humidity::strip::Refusal;
use ipmc_core::wire::stream::{DecodeError, Deframer, ErrorWindow, Frame, Header, Hygrometer, MAX_FRAME_LEN, Setup, flags};

/// One estimate, as a CSV row.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sample {
    pub t_s: f64,
    pub base_est_m: f32,
    pub rh_pct: f32,
    pub rh_strip_pct: f32,
    pub rh_read_pct: f32,
    pub rel_err: f32,
    pub hygrometer: Hygrometer,
    pub flags: u16,
}

/// A check's sample, as a check recording's row: a frame carries an earlier block's
/// (`ipmc_core::resample::track`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CheckSample {
    pub t_s: f64,
    /// The strip's current [A], as the ADC gave it.
    pub current_a: f32,
    /// The humidity sensor's reading the frame carries [%] (a reading lasts a second; the check's
    /// samples are 64 ms older than the frame).
    pub rh_read_pct: f32,
    /// The board's accelerometer, resampled onto the ADC's clock [m/s²] (NaN: the resampler had
    /// no whole block).
    pub accel_mps2: f32,
}

pub enum Event {
    Sample(Sample),
    /// A check's sample, where the frame carries a check (the board's accelerometer answered).
    Check(CheckSample),
    /// A window of the estimate's error the device measured against the check, when a frame
    /// first carries it.
    Window(WindowSample),
    /// The once-a-second display line.
    Status(String),
}

/// A window of the estimate's error measured on the device against its accelerometer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct WindowSample {
    /// The window's end [s], in the running error's count of samples from its start.
    pub t_end_s: f64,
    /// The error measured, a fraction of the reference's rms in band.
    pub measured: f32,
    /// The error the blocks stated for it (1σ, a fraction).
    pub stated: f32,
    /// Whether the frame that carried it says the calibration is stale.
    pub stale: bool,
}

/// Stream bytes → samples and status lines; independent of where the bytes come from.
pub struct Monitor {
    deframer: Box<Deframer<MAX_FRAME_LEN>>,
    fs_hz: f64,
    pub frames: u64,
    pub bad_frames: u64,
    last_error: Option<DecodeError>,
    /// 2³² per wrap of the firmware's u32 sample index (every 24.8 days at 2 kHz).
    index_offset: u64,
    last_first_sample: Option<u32>,
    /// Next whole second of stream time at which a status line is due.
    next_status_s: f64,
    /// The setup of the last frame (its outer None: no frame yet), said when it first comes and
    /// whenever it changes.
    setup: Option<Option<Setup>>,
    /// Whether the last frame carried a check (None: no frame yet), said likewise.
    check: Option<bool>,
    /// Frames that carried a check.
    pub check_frames: u64,
    /// The end of the last window of the running error said, and the windows said.
    last_window_end: Option<u32>,
    pub windows: u64,
    /// The device's stale test run again on the windows it streamed (the same f32 figures):
    /// where it does not call the calibration, how rare the error is for one that holds.
    stale_replay: StaleTest<f32>,
}

impl Monitor {
    pub fn new(fs_hz: u32) -> Self {
        Self {
            deframer: Box::new(Deframer::new()),
            fs_hz: fs_hz.max(1) as f64,
            frames: 0,
            bad_frames: 0,
            last_error: None,
            index_offset: 0,
            last_first_sample: None,
            next_status_s: f64::NEG_INFINITY,
            setup: None,
            check: None,
            check_frames: 0,
            last_window_end: None,
            windows: 0,
            stale_replay: StaleTest::new(),
        }
    }

    pub fn feed(&mut self, bytes: &[u8], mut emit: impl FnMut(Event)) {
        for &b in bytes {
            match self.deframer.push(b) {
                Some(Ok(frame)) => {
                    let frame = OwnedFrame::from(&frame);
                    self.frames += 1;
                    self.on_frame(&frame, &mut emit);
                }
                Some(Err(e)) => {
                    self.bad_frames += 1;
                    self.last_error = Some(e);
                }
                None => {}
            }
        }
    }

    fn on_frame(&mut self, f: &OwnedFrame, emit: &mut impl FnMut(Event)) {
        let h = &f.header;
        if self.setup != Some(h.setup) {
            self.setup = Some(h.setup);
            emit(Event::Status(setup_line(h.setup, self.fs_hz)));
        }
        let check = f.check.is_some();
        if self.check != Some(check) {
            self.check = Some(check);
            emit(Event::Status(check_line(check, h.setup.is_some())));
        }
        self.check_frames += u64::from(check);
        let first = h.first_sample;
        // A big step backwards is the u32 index wrapping, not a reordering (frames arrive in order).
        if self.last_first_sample.is_some_and(|last| first < last && last - first > u32::MAX / 2) {
            self.index_offset += 1 << 32;
        }
        self.last_first_sample = Some(first);
        let base_index = self.index_offset + first as u64;
        if let Some(w) = f.window
            && self.last_window_end != Some(w.end_sample)
        {
            self.last_window_end = Some(w.end_sample);
            self.windows += 1;
            let stale = h.flags & flags::CALIBRATION_STALE != 0;
            let t_end_s = w.end_sample as f64 / self.fs_hz;
            emit(Event::Window(WindowSample { t_end_s, measured: w.measured, stated: w.stated, stale }));
            emit(Event::Status(format!(
                "running error: the window ending at {t_end_s:.1} s measured {:.2} % against the accelerometer, stated {:.2} % (1σ){}",
                100.0 * w.measured,
                100.0 * w.stated,
                if stale { "; CALIBRATION_STALE: the error exceeds the stated beyond chance" } else { "" }
            )));
            self.stale_replay.push(w.measured, w.stated);
            if let Some(line) = undecided(&self.stale_replay, stale) {
                emit(Event::Status(format!("running error: {line}")));
            }
        }
        if let Some((check_first, current, accel)) = &f.check {
            // The check's block is older than the frame's: before a wrap of the index, if it is
            // the larger.
            let offset = if *check_first > first { self.index_offset.saturating_sub(1 << 32) } else { self.index_offset };
            for (k, (&current_a, &accel_mps2)) in current.iter().zip(accel).enumerate() {
                let t_s = (offset + *check_first as u64 + k as u64) as f64 / self.fs_hz;
                emit(Event::Check(CheckSample { t_s, current_a, rh_read_pct: h.rh_read_pct, accel_mps2 }));
            }
        }
        for (k, &v) in f.estimates.iter().enumerate() {
            let t_s = (base_index + k as u64) as f64 / self.fs_hz;
            let s = Sample {
                t_s,
                base_est_m: v,
                rh_pct: h.rh_pct,
                rh_strip_pct: h.rh_strip_pct,
                rh_read_pct: h.rh_read_pct,
                rel_err: h.rel_err,
                hygrometer: h.hygrometer,
                flags: h.flags,
            };
            emit(Event::Sample(s));
            if t_s >= self.next_status_s {
                self.next_status_s = t_s.floor() + 1.0;
                emit(Event::Status(self.status_line(&s)));
            }
        }
    }

    fn status_line(&self, s: &Sample) -> String {
        format!(
            "t {:10.3} s  base {:+.4e} m ± {:.1} %  RH {:6.2} % (strip {:6.2} ± {:.2} %, read {:6.2} %; own {}, fused {:6.2} ± {:.2} %)  flags {:#06x}{}  (frames {}, bad {})",
            s.t_s,
            s.base_est_m,
            100.0 * s.rel_err,
            s.rh_pct,
            s.rh_strip_pct,
            s.hygrometer.read_sd_pct,
            s.rh_read_pct,
            own(&s.hygrometer),
            s.hygrometer.fused_pct,
            s.hygrometer.fused_sd_pct,
            s.flags,
            flag_names(s.flags),
            self.frames,
            self.bad_frames
        )
    }

    pub fn summary(&self) -> String {
        let last = self.last_error.map(|e| format!(" (last: {e})")).unwrap_or_default();
        format!("{} frames decoded, {} skipped{last}", self.frames, self.bad_frames)
    }
}

/// A frame copied out of the deframer's buffer, so the deframer can take the next byte.
struct OwnedFrame {
    header: Header,
    estimates: Vec<f32>,
    /// A check's first sample, current and accelerations.
    check: Option<(u32, Vec<f32>, Vec<f32>)>,
    window: Option<ErrorWindow>,
}

impl From<&Frame<'_>> for OwnedFrame {
    fn from(f: &Frame<'_>) -> Self {
        let check =
            f.check_first_sample().zip(f.currents().zip(f.accelerations())).map(|(first, (c, a))| (first, c.collect(), a.collect()));
        Self { header: f.header, estimates: f.estimates().collect(), check, window: f.error_window() }
    }
}

/// Whether the stream carries a check, as its frames say (a frame before version 6 cannot).
fn check_line(check: bool, versioned: bool) -> String {
    match (check, versioned) {
        (true, _) => {
            "accelerometer: the board's answers, the stream carries a check (the current and the acceleration at each sample)".into()
        }
        (false, true) => "accelerometer: none in the stream so far (no part on the board, or it does not answer; where it does, a check's first samples come a few blocks after the stream's, the part's FIFO and the bus read behind)".into(),
        (false, false) => "accelerometer: none in the stream (a firmware before version 6 sends none)".into(),
    }
}

/// What the firmware runs, as its frames say (a version 4 frame says nothing).
fn setup_line(setup: Option<Setup>, fs_hz: f64) -> String {
    let Some(s) = setup else {
        return "setup: not in the stream (a version 4 firmware): a linear-phase band, the humidity its calibration set".into();
    };
    let band = Shape::from_code(s.band_shape).map_or_else(|| format!("of unknown shape ({})", s.band_shape), |b| b.name().to_string());
    let mode = match s.humidity_mode {
        0 => "the reading".to_string(),
        1 => "fused".to_string(),
        m => format!("unknown ({m})"),
    };
    format!(
        "setup: band {band}, estimates {} samples ({:.1} ms) behind the base motion, designs at the humidity {mode}",
        s.delay_samples,
        1e3 * s.delay_samples as f64 / fs_hz
    )
}

/// The strip's own estimate, or why there is none.
fn own(h: &Hygrometer) -> String {
    match h.own_refusal {
        0 => format!("{:6.2} ± {:.2} %", h.own_pct, h.own_sd_pct),
        Hygrometer::NO_FIT_YET => "no fit yet".into(),
        code => Refusal::of_code(code).map_or_else(|| format!("refused ({code})"), |r| format!("refused: {}", r.as_str())),
    }
}

fn flag_names(bits: u16) -> String {
    flags::NAMES.iter().filter(|(b, _)| bits & b != 0).map(|(_, n)| format!(" {n}")).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::wire::stream::{Check, encode, max_frame_len};

    const SETUP: Setup = Setup { band_shape: 0, delay_samples: 470, humidity_mode: 1 };

    fn frame(first: u32, rh: f32, flags: u16, est: &[f32]) -> Vec<u8> {
        frame_with(first, rh, flags, est, Some(SETUP))
    }

    fn frame_with(first: u32, rh: f32, flags: u16, est: &[f32], setup: Option<Setup>) -> Vec<u8> {
        frame_of_check(first, rh, flags, est, setup, None)
    }

    fn frame_of_check(first: u32, rh: f32, flags: u16, est: &[f32], setup: Option<Setup>, check: Option<Check<'_>>) -> Vec<u8> {
        let mut out = vec![0; max_frame_len(est.len())];
        let n = encode(
            &Header {
                first_sample: first,
                rh_pct: rh,
                rh_strip_pct: rh + 1.0,
                rh_read_pct: rh + 2.0,
                rel_err: 0.05,
                hygrometer: Hygrometer {
                    read_sd_pct: 1.5,
                    own_pct: 45.25,
                    own_sd_pct: 0.5,
                    own_refusal: 0,
                    fused_pct: 45.5,
                    fused_sd_pct: 0.25,
                },
                flags,
                setup,
            },
            est,
            check,
            &mut out,
        )
        .unwrap();
        out.truncate(n);
        out
    }

    fn run_bytes(bytes: &[u8], chunk: usize) -> (Monitor, Vec<Sample>, Vec<String>) {
        let mut m = Monitor::new(2_000);
        let (mut samples, mut lines) = (vec![], vec![]);
        for c in bytes.chunks(chunk) {
            m.feed(c, |e| match e {
                Event::Sample(s) => samples.push(s),
                Event::Check(_) | Event::Window(_) => {}
                Event::Status(l) => lines.push(l),
            });
        }
        (m, samples, lines)
    }

    /// Frames without the setup (stream version 4) and with it (version 5) are both read: the
    /// first are said to be a version 4 stream, and a change of setup mid-stream is said too.
    #[test]
    fn reads_version_4_frames_without_setup_and_version_5_frames_with_it() {
        let block = [1e-6f32; 32];
        let mut bytes = frame_with(0, 45.0, 0, &block, None);
        bytes.extend(frame_with(32, 45.0, 0, &block, None));
        bytes.extend(frame_with(64, 45.0, 0, &block, Some(Setup { band_shape: 1, delay_samples: 4, humidity_mode: 0 })));
        let (m, samples, lines) = run_bytes(&bytes, 5);
        assert_eq!((m.frames, m.bad_frames, samples.len()), (3, 0, 96));
        let setups: Vec<&String> = lines.iter().filter(|l| l.starts_with("setup:")).collect();
        assert_eq!(setups.len(), 2, "{lines:?}");
        assert!(setups[0].contains("version 4"), "{}", setups[0]);
        assert!(setups[1].contains("band low-latency, estimates 4 samples (2.0 ms)") && setups[1].contains("the reading"), "{}", setups[1]);
    }

    #[test]
    fn decodes_skips_garbage_and_bad_crc_and_counts() {
        let block: Vec<f32> = (0..32).map(|k| k as f32 * 1e-6).collect();
        let mut bytes = vec![0x13, 0x37, 0xFF, 0x42]; // joined mid-frame: garbage before the first delimiter
        bytes.push(0);
        for i in 0..200u32 {
            let mut f = frame(i * 32, 45.0 + i as f32 * 0.01, if i == 3 { flags::RETUNED } else { 0 }, &block);
            if i == 100 {
                let mid = f.len() / 2;
                f[mid] ^= 0x01; // corrupted on the wire: CRC (or COBS) rejects it
            }
            bytes.extend(f);
        }
        bytes.extend([0xAA; 5000]); // line noise longer than any frame
        bytes.push(0);
        bytes.extend(frame(200 * 32, 47.0, 0, &block));

        for chunk in [1, 7, 4096] {
            let (m, samples, lines) = run_bytes(&bytes, chunk);
            assert_eq!(m.frames, 200, "chunk {chunk}");
            assert_eq!(m.bad_frames, 3, "chunk {chunk}"); // garbage, corrupted frame, noise
            assert_eq!(samples.len(), 200 * 32);
            assert!(samples.iter().all(|s| s.base_est_m.is_finite()));
            // The corrupted frame is missing: its 32 sample times are absent, the others in order.
            assert!(samples.iter().all(|s| !(3200..3232).contains(&((s.t_s * 2000.0).round() as u64))));
            assert_eq!(samples[3 * 32].flags, flags::RETUNED);
            assert_eq!(samples.last().unwrap().t_s, (201 * 32 - 1) as f64 / 2000.0);
            // The setup and the accelerometer once, then 201 blocks of 16 ms = 3.2 s of stream:
            // lines at 0, 1, 2 and 3 s.
            assert_eq!(lines.len(), 6, "{lines:?}");
            assert_eq!(
                lines[0],
                "setup: band linear-phase, estimates 470 samples (235.0 ms) behind the base motion, designs at the humidity fused"
            );
            assert!(lines[1].starts_with("accelerometer: none in the stream so far (no part"), "{}", lines[1]);
            let lines = &lines[2..];
            assert!(lines[0].starts_with("t      0.000 s"), "{}", lines[0]);
            assert!(
                lines[0].contains("RH  45.00 % (strip  46.00 ± 1.50 %, read  47.00 %; own  45.25 ± 0.50 %, fused  45.50 ± 0.25 %)"),
                "{}",
                lines[0]
            );
            assert!(lines[0].contains("m ± 5.0 %"), "the expected error: {}", lines[0]);
            assert!(samples.iter().all(|s| s.rel_err == 0.05));
            assert!(lines.iter().any(|l| l.contains("bad 2")));
        }
    }

    /// Windows at twice the stated error, which the device's test does not call: after each the
    /// monitor says how rarely a calibration that holds shows as much, and what decides.
    #[test]
    fn an_error_the_test_does_not_call_is_said_with_its_chance() {
        let est = [1e-6f32; 32];
        let (current, accel) = ([0.0f32; 32], [0.0f32; 32]);
        let stated = 0.1f32;
        let measured = 2.0 * stated.hypot(0.01);
        let mut bytes = vec![];
        for k in 0..6u32 {
            let window = ErrorWindow { end_sample: 10_000 * (k + 1), measured, stated };
            let check = Check { first_sample: 32 * k, current_a: &current, accel_mps2: &accel, window: Some(window) };
            bytes.extend(frame_of_check(32 * (k + 1), 45.0, 0, &est, Some(SETUP), Some(check)));
        }
        let mut m = Monitor::new(2_000);
        let mut lines = vec![];
        m.feed(&bytes, |e| {
            if let Event::Status(l) = e {
                lines.push(l)
            }
        });
        let said: Vec<_> = lines.iter().filter(|l| l.starts_with("running error: not decided")).collect();
        assert_eq!((m.windows, said.len()), (6, 6), "{lines:?}");
        assert!(
            said[5].contains("2.0× the stated") && said[5].contains("at most 4.6 %") && said[5].contains("ipmc recalibrate"),
            "{}",
            said[5]
        );
    }

    /// A check's frames give its samples (an earlier block's) their current and acceleration at
    /// their own times, and the monitor says when the stream starts and stops carrying them;
    /// frames of version 4 say they cannot.
    #[test]
    fn reads_a_checks_samples_and_says_when_they_come() {
        let est = [1e-6f32; 32];
        let current: Vec<f32> = (0..32).map(|k| k as f32 * 1e-7).collect();
        let accel: Vec<f32> = (0..32).map(|k| k as f32 * 0.5 - 3.0).collect();
        let window = ErrorWindow { end_sample: 20_000, measured: 0.25, stated: 0.0625 };
        let check = |first_sample| Check { first_sample, current_a: &current, accel_mps2: &accel, window: Some(window) };
        let mut bytes = frame_with(0, 45.0, 0, &est, None);
        bytes.extend(frame_of_check(160, 45.0, 0, &est, Some(SETUP), Some(check(32))));
        bytes.extend(frame_of_check(192, 45.0, 0, &est, Some(SETUP), Some(check(64))));
        bytes.extend(frame(224, 45.0, 0, &est));
        let mut m = Monitor::new(2_000);
        let (mut samples, mut checks, mut windows, mut lines) = (vec![], vec![], vec![], vec![]);
        m.feed(&bytes, |e| match e {
            Event::Sample(s) => samples.push(s),
            Event::Check(c) => checks.push(c),
            Event::Window(w) => windows.push(w),
            Event::Status(l) => lines.push(l),
        });
        assert_eq!((m.frames, m.check_frames, samples.len(), checks.len()), (4, 2, 128, 64));
        // The window two frames carry is said once.
        assert_eq!(windows, [WindowSample { t_end_s: 10.0, measured: 0.25, stated: 0.0625, stale: false }]);
        assert!(lines.iter().any(|l| l.starts_with("running error: the window ending at 10.0 s measured 25.00 %")), "{lines:?}");
        assert!(!lines.iter().any(|l| l.contains("not decided")), "four times the stated is beyond the test's quantile: {lines:?}");
        for (k, c) in checks.iter().enumerate() {
            let expected =
                CheckSample { t_s: (32 + k) as f64 / 2000.0, current_a: current[k % 32], rh_read_pct: 47.0, accel_mps2: accel[k % 32] };
            assert_eq!(*c, expected);
        }
        let said: Vec<&String> = lines.iter().filter(|l| l.starts_with("accelerometer:")).collect();
        assert_eq!(said.len(), 3, "{lines:?}");
        assert!(said[0].contains("before version 6"), "{}", said[0]);
        assert!(said[1].contains("carries a check"), "{}", said[1]);
        assert!(said[2].contains("no part on the board"), "{}", said[2]);
    }

    #[test]
    fn sample_index_wrap_keeps_time_increasing() {
        let mut bytes = frame(u32::MAX - 31, 45.0, 0, &[0.0; 32]);
        bytes.extend(frame(0, 45.0, 0, &[0.0; 32]));
        let (_, samples, _) = run_bytes(&bytes, 64);
        assert!(samples.windows(2).all(|w| w[1].t_s > w[0].t_s));
    }

    #[test]
    fn the_strips_own_estimate_or_why_not() {
        assert_eq!(own(&Hygrometer::NONE), "no fit yet");
        assert_eq!(own(&Hygrometer { own_refusal: Refusal::Ambiguous.code(), ..Hygrometer::NONE }), "refused: ambiguous");
        assert_eq!(own(&Hygrometer { own_refusal: 0, own_pct: 72.5, own_sd_pct: 0.25, ..Hygrometer::NONE }), " 72.50 ± 0.25 %");
    }

    #[test]
    fn flag_names_list_set_bits() {
        assert_eq!(flag_names(flags::CLIPPED | flags::RETUNED), " CLIPPED RETUNED");
        assert_eq!(flag_names(0), "");
    }
}
