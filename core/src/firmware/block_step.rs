//! One block of the firmware's sample path, whole: what happens to a block of current between
//! the ADC and the stream. The firmware's sample task and the host's replay of it (`ipmc`'s
//! chain, which checks a QEMU run bit for bit) both call [`BlockStep::step`], so that the device
//! and the host agree by construction; what differs between them is only where a block's inputs
//! come from (the tasks' hand-offs, or the firmware's own record of them) and where its requests
//! go (a retune, a fit of the strip's own humidity).
//!
//! In order, for each block: the samples that are no measurement (not finite, beyond the input's
//! limit, an isolated impulse) replaced by their neighbours and counted ([`Screen`]), before
//! anything reads them; the stuck input's check; the strip's own hygrometer (a finished fit
//! first, then this block's current into its spectrum, perhaps a snapshot for the next fit); a
//! design that is ready, crossfaded to; the compensation and the block's stated error; then the
//! humidity: the reading through the calibration's humidity path, the hygrometer's humidities,
//! the fused humidity where the calibration asks for it, the distance beyond the calibrated
//! range, and a design asked for when the humidity moved. The filter and the hygrometer are the
//! two large parts (17 and 11 KiB in f32): the step borrows them, so that the firmware can make
//! each in its own static, in place, and the step itself stays small.
//!
//! The step's own functions are `#[inline]`: compiled in the crate that calls them, at its
//! opt-level (the firmware's is built for size), while the per-sample work they call is the
//! core's, at its own ([`device_calls`]).

use crate::band::BandTaps;
use crate::calibration::humidity_path::HumidityMode;
use crate::calibration::laws::Calibration;
use crate::firmware::device_calls;
use crate::firmware::operating_point::asks_for_design;
use crate::firmware::screen::Screen;
use crate::firmware::startup::Request;
use crate::firmware::stuck::StuckDetector;
use crate::humidity::block::{BlockHumidity, span_s};
use crate::humidity::hygrometer::{BlockHygrometer, Snapshot};
use crate::humidity::strip::{Refusal, StripRh};
use crate::inverse::design::{DesignConfig, Inverse};
use crate::inverse::expected_error::{BlockError, ErrorTable};
use crate::inverse::filter::Compensator;
use crate::timing::{reading_age_s, reading_is_stale};
use crate::wire::stream::{Header, Hygrometer, Setup, flags};

/// What a block brings besides its current.
#[derive(Clone, Copy, Debug)]
pub struct BlockInputs<'d> {
    /// The sample source's flags and the other tasks' conditions (`RH_STALE`, `DESIGN_FAILED`,
    /// `RH_FALLBACK`, ...), carried into the header as they are.
    pub flags: u16,
    /// Samples the source lost before this block (an overrun): the numbering and the strip's
    /// hydration go on through them.
    pub lost_samples: u32,
    /// The humidity sensor's latest reading [%] (NaN before the first).
    pub rh_read_pct: f32,
    /// How old that reading is [ms]: a reading held too long is flagged `RH_STALE` here too,
    /// since a task that no longer runs cannot say it has stopped.
    pub reading_age_ms: u64,
    /// A design made since the last block, to crossfade to.
    pub design: Option<&'d Inverse<f32>>,
}

/// What a block comes to: its header, and what it asks of the slower tasks.
#[derive(Clone, Copy, Debug)]
pub struct BlockOutputs {
    pub header: Header,
    /// The current's spectrum, for a fit of the strip's own humidity.
    pub fit_request: Option<Snapshot<f32>>,
    /// A design to make, the humidity having moved.
    pub retune: Option<Request>,
    /// The stated error's parts as the block's 1σ had them: how far beyond the calibrated range
    /// it carried the strip [%RH], and the calibration's part (NaN in a step that does not state
    /// it, `PARTS` false: the device streams only the whole).
    pub beyond_pct: f32,
    pub calibration_part: f32,
}

/// The filter's part of a block, which every chain runs as the sample path does.
#[derive(Clone, Copy, Debug)]
pub struct Filtered {
    /// A sample was not a measurement and was replaced (`BAD_SAMPLE`).
    pub bad_sample: bool,
    /// The block's stated error, 1σ (a fraction), and how far beyond the calibrated range it
    /// carried the strip [%RH].
    pub rel_err: f32,
    pub beyond_pct: f32,
}

/// The filter's part of a block: `samples` compensated in place, then their stated error. The
/// host's own chain (designs made at once, a fresh filter per burst) runs this too.
#[inline]
pub fn filter_block(filter: &mut Compensator<f32>, error_bar: &mut BlockError<'_, f32>, samples: &mut [f32]) -> Filtered {
    filtered(filter, error_bar, samples, device_calls::process_block)
}

/// [`filter_block`] with the filter's part `process`: the block step's, on samples its screen
/// has made all measurements, has no input check of its own.
#[inline]
fn filtered(
    filter: &mut Compensator<f32>,
    error_bar: &mut BlockError<'_, f32>,
    samples: &mut [f32],
    process: fn(&mut Compensator<f32>, &mut [f32]),
) -> Filtered {
    let bad_before = filter.bad_samples;
    process(filter, samples);
    let rel_err = device_calls::block_error(error_bar, filter.rh_pct(), samples);
    Filtered { bad_sample: filter.bad_samples != bad_before, rel_err, beyond_pct: error_bar.beyond_pct() }
}

/// The strip's humidity a first reading `rh_read_pct` gives the first block, before any:
/// what the start-up designs for (None: no humidity in it).
#[inline]
pub fn first_design_rh(calibration: &Calibration, rh_read_pct: f32) -> Option<f32> {
    BlockHumidity::<f32>::new(calibration, reading_age_s()).advance(rh_read_pct, 0.0).map(|first| first.rh_pct)
}

/// The sample path's state from block to block, the filter and the hygrometer borrowed.
/// `PARTS`: each block's outputs carry the calibration's part of its 1σ (the host's estimate
/// files); the device's step, without, has no code for it.
pub struct BlockStep<'a, const PARTS: bool = false> {
    filter: &'a mut Compensator<f32>,
    hygrometer: &'a mut BlockHygrometer<f32>,
    /// Samples that are no measurement, replaced before the block is read.
    screen: Screen<f32>,
    /// One second of identical samples is no live front end.
    stuck: StuckDetector<f32>,
    humidity: BlockHumidity<f32>,
    /// The fused humidity through the strip's part of the path, where the designs follow it
    /// (the strip's humidity already: no second correction); None where they follow the reading.
    fused: Option<BlockHumidity<f32>>,
    error_bar: BlockError<'a, f32>,
    /// RH of the active or already requested design.
    design_rh: f32,
    /// Whether the active design is the start-up's fallback: the first reading replaces it even
    /// within the retune threshold, so that `RH_FALLBACK` always clears.
    on_fallback: bool,
    /// Samples from the previous block's start to this one's (0 before the first: the strip
    /// starts settled at the first reading).
    since_last: u32,
    first_sample: u32,
    fs_hz: u32,
    setup: Option<Setup>,
}

impl<'a, const PARTS: bool> BlockStep<'a, PARTS> {
    /// For `calibration`'s chain at `fs_hz` (a whole number of hertz, as on the device), its
    /// stated error from `errors`; `filter` passes through until [`start`](Self::start). `setup`
    /// goes into every header.
    #[inline]
    pub fn new(
        calibration: &Calibration,
        errors: &'a ErrorTable,
        fs_hz: u32,
        filter: &'a mut Compensator<f32>,
        hygrometer: &'a mut BlockHygrometer<f32>,
        setup: Option<Setup>,
    ) -> Self {
        let fused = (calibration.humidity.mode() == HumidityMode::Fused)
            .then(|| BlockHumidity::new(&Calibration { humidity: calibration.humidity.at_strip(), ..*calibration }, reading_age_s()));
        BlockStep {
            filter,
            hygrometer,
            screen: Screen::new(),
            stuck: StuckDetector::new(fs_hz),
            humidity: BlockHumidity::new(calibration, reading_age_s()),
            fused,
            error_bar: BlockError::new(errors, &DesignConfig::at_rate(fs_hz as f32)),
            design_rh: f32::NAN,
            on_fallback: false,
            since_last: 0,
            first_sample: 0,
            fs_hz,
            setup,
        }
    }

    /// Starts on the first design, in place; `fallback`: it is the start-up's fallback. Every
    /// design is the calibration's, at its band and this rate, which the filter keeps.
    #[inline]
    pub fn start(&mut self, first: &Inverse<f32>, fallback: bool) {
        let kept = self.filter.restart_in_band(first);
        debug_assert!(kept, "a design for another band or rate than the filter's");
        self.design_rh = first.rh_pct();
        self.on_fallback = fallback;
    }

    /// One block: `samples` holds its current [A] and leaves with its estimates [m]; `fit` is a
    /// fit of the strip's humidity finished since the last block.
    #[inline]
    pub fn step(&mut self, samples: &mut [f32], fit: Option<Result<StripRh<f32>, Refusal>>, input: &BlockInputs) -> BlockOutputs {
        self.first_sample = self.first_sample.wrapping_add(input.lost_samples);
        // The strip dried or wetted through the lost samples too.
        self.since_last += input.lost_samples;
        let mut header = Header {
            first_sample: self.first_sample,
            rh_pct: 0.0,
            rh_strip_pct: f32::NAN,
            rh_read_pct: input.rh_read_pct,
            rel_err: f32::NAN,
            hygrometer: Hygrometer::NONE,
            flags: input.flags,
            setup: self.setup,
        };
        let raise = |on: bool, flag: u16| if on { flag } else { 0 };
        // Made here, at the calling crate's opt-level (the firmware's is built for size): a
        // scan and a pass a block, outside the per-sample budget of `device_calls`.
        let replaced = self.screen.block(samples, |_, _, _| {});
        header.flags |= raise(device_calls::observe_stuck(&mut self.stuck, samples), flags::STUCK);

        // The hygrometer: a finished fit first, then this block's current into the spectrum.
        header.flags |= raise(fit.is_some(), flags::FIT_DONE);
        if let Some(result) = fit {
            self.hygrometer.complete(result);
        }
        let fit_request = device_calls::push_current(self.hygrometer, samples, self.humidity.strip_pct());
        header.flags |= raise(fit_request.is_some(), flags::FIT_STARTED);

        header.flags |= raise(input.design.is_some(), flags::RETUNED);
        if let Some(design) = input.design {
            device_calls::switch_to(self.filter, design);
        }
        let filtered = filtered(self.filter, &mut self.error_bar, samples, device_calls::process_screened_block);
        header.flags |= raise(replaced > 0 || filtered.bad_sample, flags::BAD_SAMPLE);
        header.rel_err = filtered.rel_err;
        let beyond_pct = filtered.beyond_pct;
        let calibration_part = if PARTS { self.error_bar.parts(self.filter.rh_pct()).0 } else { f32::NAN };

        header.flags |= raise(input.rh_read_pct.is_finite() && reading_is_stale(input.reading_age_ms), flags::RH_STALE);
        // No reading yet: the first design is the start-up's fallback, and stays.
        let mut retune = None;
        let dt_s = span_s(self.since_last, self.fs_hz);
        if let Some(read) = self.humidity.advance(input.rh_read_pct, dt_s) {
            header.rh_strip_pct = self.humidity.strip_pct().unwrap_or(read.rh_pct);
            let h = self.hygrometer.humidities(header.rh_strip_pct);
            header.hygrometer = h.to_wire();
            header.flags |= raise(!matches!(h.strip, Some(Ok(_))), flags::OWN_REFUSED);
            let now = match self.fused.as_mut() {
                Some(fused) => fused.advance(h.fused.rh_pct, dt_s).unwrap_or(read),
                None => read,
            };
            self.error_bar.beyond_range(now.beyond_pct);
            header.flags |= raise(now.clamped, flags::RH_CLAMPED);
            if core::mem::take(&mut self.on_fallback) | asks_for_design(self.design_rh, now.rh_pct, self.filter.is_retuning()) {
                self.design_rh = now.rh_pct;
                retune = Some(Request { rh_pct: now.rh_pct, fallback: false });
            }
        }
        self.since_last = samples.len() as u32;
        header.rh_pct = self.filter.rh_pct();
        self.first_sample = self.first_sample.wrapping_add(samples.len() as u32);
        BlockOutputs { header, fit_request, retune, beyond_pct, calibration_part }
    }

    /// Samples replaced as no measurement since the start ([`Screen`]).
    pub fn bad_samples(&self) -> u32 {
        self.screen.replaced
    }

    /// The estimates' delay behind the base motion [s].
    pub fn delay_s(&self) -> f32 {
        self.filter.delay_s()
    }

    /// The coefficients of the estimate's band filter where it runs (the running error's
    /// reference runs them).
    pub fn band_taps(&self) -> Option<&BandTaps<f32>> {
        self.filter.band_taps()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design_inverse;
    use crate::timing::{BLOCK_LEN, SAMPLE_RATE_HZ};
    use std::vec;
    use std::vec::Vec;

    /// One step after another: the numbering through lost samples, a fit asked for once a
    /// second of current has come, a design crossfaded to where one is given, a retune asked for
    /// when the humidity moved, a sample that is no measurement flagged.
    #[test]
    fn a_block_comes_to_its_header_and_requests() {
        let calib = Calibration::default_preset();
        let cfg = DesignConfig::<f32>::firmware();
        let errors = ErrorTable::new(&calib, None, 1.0, &DesignConfig::<f64>::firmware()).unwrap();
        let first = design_inverse::<f32>(&calib, 50.0, &cfg).unwrap();
        let mut filter = Compensator::passthrough(&first.band(), first.fs_hz());
        let mut hygrometer = BlockHygrometer::new(&calib, SAMPLE_RATE_HZ as f64);
        let mut step = BlockStep::<true>::new(&calib, &errors, SAMPLE_RATE_HZ, &mut filter, &mut hygrometer, None);
        step.start(&first, false);
        let tone = |k: usize| -> [f32; BLOCK_LEN] { core::array::from_fn(|i| 1e-8 * libm::sinf(0.3 * (k * BLOCK_LEN + i) as f32)) };
        let input = |rh: f32, lost: u32| BlockInputs { flags: 0, lost_samples: lost, rh_read_pct: rh, reading_age_ms: 0, design: None };

        let out = step.step(&mut tone(0), None, &input(50.0, 0));
        assert_eq!(out.header.first_sample, 0);
        // The band's filter has not let anything through yet: no signal to be relative to.
        assert!(out.header.rh_strip_pct.is_finite() && out.calibration_part.is_finite() && out.header.rel_err.is_infinite());
        let out = step.step(&mut tone(1), None, &input(50.0, 5));
        assert_eq!(out.header.first_sample, BLOCK_LEN as u32 + 5, "lost samples count in the numbering");

        let mut fits: Vec<usize> = vec![];
        for k in 2..70 {
            let out = step.step(&mut tone(k), None, &input(50.0, 0));
            assert_eq!(out.fit_request.is_some(), out.header.flags & flags::FIT_STARTED != 0);
            if out.fit_request.is_some() {
                fits.push(k);
            }
            assert!(out.retune.is_none(), "the humidity did not move: no design asked for");
        }
        // A second of samples (2000) is reached in the 63rd block, the 5 lost ones counted.
        assert_eq!(fits, vec![62], "one fit asked for, once a second of current has come");

        let mut asked = None;
        for k in 70..400 {
            if let Some(r) = step.step(&mut tone(k), None, &input(60.0, 0)).retune {
                asked = Some(r.rh_pct);
                break;
            }
        }
        let asked = asked.expect("the humidity moved by 10 %RH: a design is asked for");
        let next = design_inverse::<f32>(&calib, asked, &cfg).unwrap();
        let out = step.step(&mut tone(400), None, &BlockInputs { design: Some(&next), ..input(60.0, 0) });
        assert!(out.header.flags & flags::RETUNED != 0);
        assert_eq!(out.header.rh_pct, asked);

        let mut bad = tone(401);
        bad[3] = f32::NAN;
        let out = step.step(&mut bad, None, &input(60.0, 0));
        assert!(out.header.flags & flags::BAD_SAMPLE != 0 && bad.iter().all(|v| v.is_finite()));
        let out = step.step(&mut tone(402), None, &input(f32::NAN, 0));
        assert!(out.header.rh_strip_pct.is_nan() && out.retune.is_none(), "no reading, no humidity");
    }

    /// The device's step over a broadband current twice, once with one sample a 1 mA spike and
    /// once a 1e30: the spike's block alone is flagged and the step counts one bad sample; every
    /// header is the clean run's but for that flag (its stated error within 1e-3), the estimates before the spike are the clean
    /// run's bit for bit and after it within 1e-3 of the estimate's rms (the neighbours' mean
    /// for the clean sample, through the filter).
    #[test]
    fn one_bad_sample_is_counted_flagged_and_leaves_the_estimate() {
        let calib = Calibration::default_preset();
        let cfg = DesignConfig::<f32>::firmware();
        let errors = ErrorTable::new(&calib, None, 1.0, &DesignConfig::<f64>::firmware()).unwrap();
        let first = design_inverse::<f32>(&calib, 50.0, &cfg).unwrap();
        let blocks = 6 * SAMPLE_RATE_HZ as usize / BLOCK_LEN;
        let current = |i: usize| {
            let t = i as f32 / SAMPLE_RATE_HZ as f32;
            let w = 2.0 * core::f32::consts::PI;
            2e-7 * (libm::sinf(w * 23.0 * t) + 0.6 * libm::sinf(w * 71.0 * t + 1.0) + 0.4 * libm::sinf(w * 133.0 * t + 2.0))
        };
        let at = 3 * SAMPLE_RATE_HZ as usize + 17;
        let run = |bad: Option<f32>| {
            let mut filter = Compensator::passthrough(&first.band(), first.fs_hz());
            let mut hygrometer = BlockHygrometer::new(&calib, SAMPLE_RATE_HZ as f64);
            let mut step = BlockStep::<false>::new(&calib, &errors, SAMPLE_RATE_HZ, &mut filter, &mut hygrometer, None);
            step.start(&first, false);
            let input = BlockInputs { flags: 0, lost_samples: 0, rh_read_pct: 50.0, reading_age_ms: 0, design: None };
            let mut out = vec![];
            for k in 0..blocks {
                let mut block: [f32; BLOCK_LEN] = core::array::from_fn(|i| current(k * BLOCK_LEN + i));
                if let Some(v) = bad.filter(|_| at / BLOCK_LEN == k) {
                    block[at % BLOCK_LEN] = v;
                }
                let o = step.step(&mut block, None, &input);
                out.push((o.header, block));
            }
            (out, step.bad_samples())
        };
        let (clean, none) = run(None);
        assert_eq!(none, 0, "nothing in a clean current is a bad sample");
        let rms = (clean.iter().flat_map(|(_, b)| b.iter()).map(|v| v * v).sum::<f32>() / (blocks * BLOCK_LEN) as f32).sqrt();
        for bad in [1e-3, 1e30] {
            let (spiked, count) = run(Some(bad));
            assert_eq!(count, 1, "{bad:e}: counted once");
            for (k, ((h, b), (hc, bc))) in spiked.iter().zip(&clean).enumerate() {
                let flagged = h.flags & flags::BAD_SAMPLE != 0;
                assert_eq!(flagged, k == at / BLOCK_LEN, "{bad:e}: block {k} flags {:#x}", h.flags);
                assert_eq!(h.flags & !flags::BAD_SAMPLE, hc.flags);
                assert_eq!(h.rh_pct, hc.rh_pct, "{bad:e}: block {k}'s design");
                let same_err = h.rel_err == hc.rel_err || (h.rel_err / hc.rel_err - 1.0).abs() < 1e-3;
                assert!(same_err, "{bad:e}: block {k} states {} for {}", h.rel_err, hc.rel_err);
                for (i, (y, yc)) in b.iter().zip(bc).enumerate() {
                    let n = k * BLOCK_LEN + i;
                    if n < at {
                        assert_eq!(y.to_bits(), yc.to_bits(), "{bad:e}: estimate {n}, before the spike");
                    } else {
                        assert!((y - yc).abs() <= 1e-3 * rms, "{bad:e}: estimate {n} moved {:e} (rms {rms:e})", y - yc);
                    }
                }
            }
        }
    }
}
