//! The per-sample path: current block → the core's block step → report queue. Runs at the
//! highest priority; after start-up it never waits for anything but the next block of samples.
//! What a block comes to is the core's (`ipmc_core::firmware::block_step`, which the host's
//! replay runs too); this task only wires it to the signals of the other tasks: the designs
//! and the hygrometer's fits in, the retune and fit requests and the estimates out, and where the
//! board's accelerometer answers, the check's samples beside them (`check`).

use ipmc_core::firmware::block_step::{BlockInputs, BlockStep};
use ipmc_core::wire::stream::ErrorWindow;

use super::compensation::{RunningError, measure_error};

use super::handoff::{
    self, CHECKS, DESIGN_READY, EstimateBlock, FIT_REQUEST, FIT_RESULT, LATEST_READ_RH_PCT, REPORT_QUEUE, RETUNE_REQUEST, ReportItem,
};
use crate::board::{Accelerometer, Samples};
use crate::contract::{
    config::BLOCK_LEN,
    flags,
    sources::{AccelSource, CurrentSource, SampleBlock},
};

#[embassy_executor::task]
pub async fn sample_task(
    mut samples: Samples,
    accel: &'static mut Accelerometer,
    step: &'static mut BlockStep<'static>,
    mut error: Option<&'static mut RunningError>,
) {
    // Start-up only: sampling begins once the first design exists, so every reported
    // estimate comes from a real filter. The first design is the start-up's fallback when
    // the humidity task says so.
    // In a scope of its own: the design is 0.9 KB, which the task's state would otherwise keep
    // beside the loop's for good.
    {
        let first = DESIGN_READY.wait().await;
        step.start(&first, handoff::conditions() & flags::RH_FALLBACK != 0);
        defmt::info!("sampling starts, design for {} %RH", first.rh_pct());
    }

    samples.start();
    let mut blocks: u32 = 0;
    let mut dropped_since_last = false;
    // The last window's test of the calibration, raised on every block until the next window
    // and while checks come; the window itself streamed beside the checks the same way.
    let mut stale = false;
    let mut window = None;
    loop {
        let mut base_est_m = [0.0; BLOCK_LEN];
        let (source_flags, lost_samples) = match samples.read_block(&mut base_est_m).await {
            SampleBlock::Ready { flags, lost_samples } => (flags, lost_samples),
            SampleBlock::End => break,
        };
        // The current as the ADC gave it, before the step makes estimates of it in place.
        let current_a = base_est_m;
        let mut header = run_step(step, &mut base_est_m, source_flags, lost_samples);
        let mut check = accel.check(header.first_sample, lost_samples > 0, &current_a);
        if let Some(m) = error.as_deref_mut() {
            let accel_mps2 = check.as_ref().map(|c| &c.accel_mps2);
            if let Some(w) = measure_error(m, step, &base_est_m, header.rel_err, accel_mps2) {
                stale = w.stale;
                window = Some(ErrorWindow { end_sample: w.end as u32, measured: w.measured, stated: w.stated });
            }
        }
        stale &= check.is_some();
        if let Some(c) = check.as_mut() {
            c.window = window;
        } else {
            window = None;
        }
        if stale {
            header.flags |= flags::CALIBRATION_STALE;
        }
        if dropped_since_last {
            header.flags |= flags::REPORT_DROPPED;
        }
        // Only this task sends: with room in the queue now, the block's send below succeeds.
        let has_check = check.is_some_and(|c| !REPORT_QUEUE.is_full() && CHECKS.try_send(c).is_ok());
        dropped_since_last = REPORT_QUEUE.try_send(ReportItem::Block(EstimateBlock { header, base_est_m, has_check })).is_err();
        blocks += 1;
    }
    // End of a replay: waiting is fine now, nothing is sampled any more.
    REPORT_QUEUE.send(ReportItem::End { blocks }).await;
}

/// One block through the step: its inputs taken from the other tasks' hand-offs, its requests
/// handed to them.
#[inline(never)]
fn run_step(
    step: &mut BlockStep<'static>,
    block: &mut [f32; BLOCK_LEN],
    source_flags: u16,
    lost_samples: u32,
) -> ipmc_core::wire::stream::Header {
    let design = DESIGN_READY.try_take();
    let input = BlockInputs {
        flags: source_flags | handoff::conditions(),
        lost_samples,
        rh_read_pct: LATEST_READ_RH_PCT.load(),
        reading_age_ms: handoff::reading_age_ms(embassy_time::Instant::now()),
        design: design.as_ref(),
    };
    let out = step.step(block, FIT_RESULT.try_take(), &input);
    if let Some(snapshot) = out.fit_request {
        FIT_REQUEST.signal(snapshot);
    }
    if let Some(request) = out.retune {
        RETUNE_REQUEST.signal(request);
    }
    out.header
}
