//! The seam to ipmc-core: every call into the physics/filter crate goes through here, so the
//! tasks read as data flow and the core API is named in one place.

use ipmc_core::{
    Calibration, Compensator, DesignConfig, DesignError, Inverse,
    firmware::block_step::{self, BlockStep},
    firmware::device_calls,
    firmware::running_error::Window,
    humidity::hygrometer::{BlockHygrometer, Snapshot, noise_psd},
    humidity::strip::{Refusal, StripRh},
    inverse::expected_error::ErrorTable,
    wire::stream::Setup,
};
use static_cell::{ConstStaticCell, StaticCell};

use crate::contract::calibration::BandLinesOfPlan;

use crate::contract::config::{BLOCK_LEN, SAMPLE_RATE_HZ};

/// The calibration compiled into this firmware (see `contract::calibration`: chosen at build time).
/// By reference: its one copy in flash; taken by value, each caller copied its 3 KB (most of it
/// the room for a `[departures]` table) to its stack or its task's RAM.
pub fn calibration() -> &'static Calibration {
    static CALIBRATION: Calibration = crate::contract::calibration::CALIBRATION;
    &CALIBRATION
}

/// The expected error of the calibration's designs over humidity, tabulated at build time. By
/// reference, as the calibration: its one copy in flash.
pub fn error_table() -> &'static ErrorTable {
    static ERROR_TABLE: ErrorTable = crate::contract::calibration::ERROR_TABLE;
    &ERROR_TABLE
}

/// The strip's humidity from a snapshot of its current's spectrum, with the model table baked
/// for this calibration. Slow: runs in the fit task only.
pub fn fit(snapshot: &Snapshot<f32>) -> Result<StripRh<f32>, Refusal> {
    ipmc_hygrometer_fit::fit(&crate::contract::calibration::STRIP_TABLE, &snapshot.view(), noise_psd(calibration()))
}

/// Slow: runs in the retune task only.
pub fn design(calibration: &Calibration, rh_pct: f32) -> Result<Inverse<f32>, DesignError> {
    device_calls::design(calibration, rh_pct)
}

/// The strip's humidity a first reading gives, as the sample path's first block will have it.
pub fn first_design_rh(rh_read_pct: f32) -> Option<f32> {
    block_step::first_design_rh(calibration(), rh_read_pct)
}

static FILTER: StaticCell<Compensator<f32>> = StaticCell::new();
static HYGROMETER: StaticCell<BlockHygrometer<f32>> = StaticCell::new();
static STEP: StaticCell<BlockStep<'static>> = StaticCell::new();

/// The sample path's block step and its two large parts (the filter, 17 KiB, and the strip's
/// own hygrometer, 11 KiB), each made in its own static at boot, in thread mode before any
/// executor runs, by a function of its own: a construction's stack then meets nothing else
/// there, and leaves with its frame. The interrupt that runs the step holds one block's
/// temporaries, not the state: that frame comes on top of whatever thread mode is doing when a
/// block arrives (the hygrometer's fit at its deepest).
#[inline(never)]
pub fn block_step() -> &'static mut BlockStep<'static> {
    make_step(make_filter())
}

/// The filter before the first design: the current through the calibration's band, whose
/// filter was baked at build time (the device never designs a band).
#[inline(never)]
fn make_filter() -> &'static mut Compensator<f32> {
    // The band as the designs will state it (its edges through f32), at the designs' rate.
    let band = ipmc_core::inverse::design::design_band::<f32>(calibration());
    let filter = FILTER.init_with(|| Compensator::unbanded(&band, DesignConfig::<f32>::firmware().fs_hz));
    filter.keep_band_designed(&crate::contract::calibration::BAND);
    filter
}

/// The hygrometer and the step around the filter.
#[inline(never)]
fn make_step(filter: &'static mut Compensator<f32>) -> &'static mut BlockStep<'static> {
    let calibration = calibration();
    let hygrometer = HYGROMETER.init_with(|| BlockHygrometer::new(calibration, SAMPLE_RATE_HZ as f64));
    let setup = Setup {
        band_shape: calibration.band.shape.code(),
        delay_samples: crate::contract::calibration::DELAY_SAMPLES,
        humidity_mode: calibration.humidity.mode().code(),
    };
    STEP.init_with(|| BlockStep::new(calibration, error_table(), SAMPLE_RATE_HZ, filter, hygrometer, Some(setup)))
}

/// The estimate's error measured against the board's accelerometer, its band filter's lines
/// sized to the one plan baked (`contract::calibration::BandLinesOfPlan`).
pub type RunningError = ipmc_core::firmware::running_error::RunningError<f32, BandLinesOfPlan>;

/// In a const: in the zeroed RAM, no code made to lay it down; set up where it is.
static RUNNING_ERROR: ConstStaticCell<RunningError> = ConstStaticCell::new(RunningError::empty(0.0));

/// The running error, set up in its static at boot, where the step's band filter runs (none
/// where the filter keeps no band: nothing to measure in).
#[inline(never)]
pub fn running_error(step: &BlockStep<'static>) -> Option<&'static mut RunningError> {
    step.band_taps()?;
    let m = RUNNING_ERROR.take();
    m.start(SAMPLE_RATE_HZ as f64, crate::contract::calibration::PREVIEW_SAMPLES);
    Some(m)
}

/// A block's estimates [m] and their stated error into the running error, with the check's
/// accelerometer [m/s²] where one came (an earlier block's): a window, where one ends.
#[inline(never)]
pub fn measure_error(
    m: &mut RunningError,
    step: &BlockStep<'static>,
    estimate: &[f32; BLOCK_LEN],
    stated: f32,
    accel: Option<&[f32; BLOCK_LEN]>,
) -> Option<Window<f32>> {
    let taps = step.band_taps()?;
    let (measure, lines) = m.parts();
    let mut reference = [0.0; BLOCK_LEN];
    device_calls::running_error_block(measure, lines, taps, estimate, stated, accel.map(|a| &a[..]), &mut reference)
}
