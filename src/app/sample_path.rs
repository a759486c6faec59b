//! The per-sample path: current block → compensation → report queue. Runs at the highest
//! priority; after start-up it never waits for anything but the next block of samples. Each
//! block also advances the strip's humidity by its own duration (`ipmc_core::humidity::block`)
//! and asks for a design when that moved away from the active one. Its current also feeds the
//! strip's own hygrometer (`ipmc_core::humidity::hygrometer`: a spectrum here, the fit in the fit
//! task); with a `fused` calibration the design follows the fused humidity instead of the
//! reading's.

use core::ptr::addr_of_mut;
use ipmc_core::{
    Inverse,
    calibration::humidity_path::HumidityMode,
    firmware::device_calls,
    firmware::operating_point::asks_for_design,
    firmware::startup::Request,
    firmware::stuck::StuckDetector,
    humidity::block::{BlockHumidity, span_s},
    humidity::hygrometer::BlockHygrometer,
    inverse::expected_error::BlockError,
    timing::{reading_age_s, reading_is_stale},
    wire::stream::{Header, Hygrometer, Setup},
};
use static_cell::StaticCell;

use crate::board::Samples;

use super::{
    compensation::SamplePathFilter,
    handoff::{self, DESIGN_READY, EstimateBlock, FIT_REQUEST, FIT_RESULT, LATEST_READ_RH_PCT, REPORT_QUEUE, RETUNE_REQUEST, ReportItem},
};
use crate::contract::{
    config::{BLOCK_LEN, SAMPLE_RATE_HZ},
    flags,
    sources::{CurrentSource, SampleBlock},
};

#[embassy_executor::task]
pub async fn sample_task(mut samples: Samples, path: &'static mut SamplePath) {
    // Start-up only: sampling begins once the first design exists, so every reported
    // estimate comes from a real filter.
    let first = DESIGN_READY.wait().await;
    path.start(&first);
    defmt::info!("sampling starts, design for {} %RH", first.rh_pct());

    let calibration = super::compensation::calibration();
    let setup = Setup {
        band_shape: calibration.band.shape.code(),
        delay_samples: crate::contract::calibration::DELAY_SAMPLES,
        humidity_mode: calibration.humidity.mode().code(),
    };
    samples.start();
    let mut blocks: u32 = 0;
    let mut dropped_since_last = false;
    loop {
        let mut block = EstimateBlock {
            header: Header {
                first_sample: 0,
                rh_pct: 0.0,
                rh_strip_pct: f32::NAN,
                rh_read_pct: 0.0,
                rel_err: f32::NAN,
                hygrometer: Hygrometer::NONE,
                flags: 0,
                setup: Some(setup),
            },
            base_est_m: [0.0; BLOCK_LEN],
        };
        let (source_flags, lost_samples) = match samples.read_block(&mut block.base_est_m).await {
            SampleBlock::Ready { flags, lost_samples } => (flags, lost_samples),
            SampleBlock::End => break,
        };
        path.block(&mut block, source_flags, lost_samples);
        if dropped_since_last {
            block.header.flags |= flags::REPORT_DROPPED;
        }
        dropped_since_last = REPORT_QUEUE.try_send(ReportItem::Block(block)).is_err();
        blocks += 1;
    }
    // End of a replay: waiting is fine now, nothing is sampled any more.
    REPORT_QUEUE.send(ReportItem::End { blocks }).await;
}

/// What the sample path keeps from block to block: the filter, the strip's humidity and its
/// own hygrometer's spectrum, about 31 KiB. It lives in a static made at boot, and the per-block
/// work is a function of its own: the interrupt's stack frame then holds one block's
/// temporaries, not the state. That frame comes on top of whatever thread mode is in when the
/// block arrives (the hygrometer's fit at its deepest); with the state built inside the task's
/// poll, the two overflowed the stack (a lockup under QEMU on a loaded machine).
pub struct SamplePath {
    filter: SamplePathFilter,
    /// One second of identical samples is no live front end (see ipmc_core::firmware::stuck).
    stuck: StuckDetector<f32>,
    humidity: BlockHumidity<f32>,
    hygrometer: BlockHygrometer<f32>,
    /// Fused: the designs follow the fused humidity, the strip's already (no second correction).
    fused_mode: bool,
    fused: BlockHumidity<f32>,
    error_bar: BlockError<f32>,
    /// RH of the active or already requested design.
    design_rh: f32,
    /// Whether the active design is the start-up's fallback.
    on_fallback: bool,
    /// Samples from the previous block's start to this one's (0 before the first: the strip
    /// starts settled at the first reading).
    since_last: u32,
    first_sample: u32,
}

static SAMPLE_PATH: StaticCell<SamplePath> = StaticCell::new();

/// # Safety
/// `slot` is valid for a write.
#[inline(never)]
unsafe fn write_filter(slot: *mut SamplePathFilter) {
    unsafe {
        slot.write(SamplePathFilter::passthrough());
        (*slot).keep_band();
    }
}

/// # Safety
/// `slot` is valid for a write.
#[inline(never)]
unsafe fn write_hygrometer(slot: *mut BlockHygrometer<f32>) {
    let calibration = super::compensation::calibration();
    unsafe { slot.write(BlockHygrometer::new(calibration, SAMPLE_RATE_HZ as f64)) }
}

impl SamplePath {
    /// At boot, in thread mode before any executor runs, so that whatever a construction puts
    /// on the stack meets nothing else there. Field by field into the static: built as one value,
    /// the compiler made it on the stack and copied it (69 KiB of frame, more than the stack);
    /// the two large fields each come from a constructor of their own writing straight to its
    /// place, and leave with its frame.
    #[inline(never)]
    pub fn prepare() -> &'static mut SamplePath {
        let calibration = super::compensation::calibration();
        let cell = SAMPLE_PATH.uninit();
        let p = cell.as_mut_ptr();
        // SAFETY: `p` is the static's own storage, handed out once by `uninit`; each field is
        // written once, through raw pointers (no reference to the uninitialized whole), and
        // the whole is assumed initialized only after the last.
        unsafe {
            write_filter(addr_of_mut!((*p).filter));
            write_hygrometer(addr_of_mut!((*p).hygrometer));
            addr_of_mut!((*p).stuck).write(StuckDetector::new(SAMPLE_RATE_HZ));
            addr_of_mut!((*p).humidity).write(BlockHumidity::new(calibration, reading_age_s()));
            addr_of_mut!((*p).fused_mode).write(calibration.humidity.mode() == HumidityMode::Fused);
            addr_of_mut!((*p).fused).write(BlockHumidity::new(
                &ipmc_core::Calibration { humidity: calibration.humidity.at_strip(), ..*calibration },
                reading_age_s(),
            ));
            addr_of_mut!((*p).error_bar).write(BlockError::new(&super::compensation::error_table(), &ipmc_core::DesignConfig::firmware()));
            addr_of_mut!((*p).design_rh).write(f32::NAN);
            addr_of_mut!((*p).on_fallback).write(false);
            addr_of_mut!((*p).since_last).write(0);
            addr_of_mut!((*p).first_sample).write(0);
            cell.assume_init_mut()
        }
    }

    /// The first design: the filter starts on it, in place.
    fn start(&mut self, first: &Inverse<f32>) {
        self.filter.restart(first);
        self.design_rh = first.rh_pct();
        // The first design is the start-up's fallback when the humidity task says so: the first
        // reading then replaces it even within the retune threshold, so that RH_FALLBACK always
        // clears.
        self.on_fallback = handoff::conditions() & flags::RH_FALLBACK != 0;
    }

    /// One block of current [A] in `block.base_est_m` → its estimates and header.
    #[inline(never)]
    fn block(&mut self, block: &mut EstimateBlock, source_flags: u16, lost_samples: u32) {
        self.first_sample = self.first_sample.wrapping_add(lost_samples);
        block.header.first_sample = self.first_sample;
        // The strip dried or wetted through the lost samples too.
        self.since_last += lost_samples;
        block.header.flags = source_flags | handoff::conditions();
        if device_calls::observe_stuck(&mut self.stuck, &block.base_est_m) {
            block.header.flags |= flags::STUCK;
        }

        // The hygrometer: a finished fit first, then this block's current into the spectrum (the
        // order the host replays).
        if let Some(result) = FIT_RESULT.try_take() {
            self.hygrometer.complete(result);
            block.header.flags |= flags::FIT_DONE;
        }
        if let Some(snapshot) = device_calls::push_current(&mut self.hygrometer, &block.base_est_m, self.humidity.strip_pct()) {
            FIT_REQUEST.signal(snapshot);
            block.header.flags |= flags::FIT_STARTED;
        }

        if let Some(design) = DESIGN_READY.try_take() {
            self.filter.switch_to(&design);
            block.header.flags |= flags::RETUNED;
        }
        if self.filter.process(&mut block.base_est_m) {
            block.header.flags |= flags::BAD_SAMPLE;
        }
        block.header.rel_err = device_calls::block_error(&mut self.error_bar, self.filter.rh_pct(), &block.base_est_m);

        block.header.rh_read_pct = LATEST_READ_RH_PCT.load();
        // The humidity task flags its own failures; a wedged I/O executor runs no task to do so,
        // so the reading's age is judged here too (before the first reading, RH_FALLBACK says it).
        if block.header.rh_read_pct.is_finite() && reading_is_stale(handoff::reading_age_ms(embassy_time::Instant::now())) {
            block.header.flags |= flags::RH_STALE;
        }
        // No reading yet: the first design is the humidity task's fallback, and stays.
        let dt_s = span_s(self.since_last, SAMPLE_RATE_HZ);
        if let Some(read) = self.humidity.advance(block.header.rh_read_pct, dt_s) {
            block.header.rh_strip_pct = self.humidity.strip_pct().unwrap_or(read.rh_pct);
            let h = self.hygrometer.humidities(block.header.rh_strip_pct);
            block.header.hygrometer = h.to_wire();
            if !matches!(h.strip, Some(Ok(_))) {
                block.header.flags |= flags::OWN_REFUSED;
            }
            let now = if self.fused_mode { self.fused.advance(h.fused.rh_pct, dt_s).unwrap_or(read) } else { read };
            self.error_bar.beyond_range(now.beyond_pct);
            if now.clamped {
                block.header.flags |= flags::RH_CLAMPED;
            }
            if core::mem::take(&mut self.on_fallback) | asks_for_design(self.design_rh, now.rh_pct, self.filter.is_retuning()) {
                self.design_rh = now.rh_pct;
                RETUNE_REQUEST.signal(Request { rh_pct: now.rh_pct, fallback: false });
            }
        }
        self.since_last = BLOCK_LEN as u32;
        block.header.rh_pct = self.filter.rh_pct();
        self.first_sample = self.first_sample.wrapping_add(BLOCK_LEN as u32);
    }
}
