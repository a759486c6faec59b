//! The per-sample path: current block → compensation → report queue. Runs at the highest
//! priority; after start-up it never waits for anything but the next block of samples. Each
//! block also advances the strip's humidity by its own duration (`ipmc_core::block_humidity`)
//! and asks for a design when that moved away from the active one.

use ipmc_core::{
    block_humidity::{BlockHumidity, span_s},
    expected_error::BlockError,
    operating_point::{asks_for_design, reading_age_s},
    startup::Request,
    stream::Header,
    stuck::StuckDetector,
};

use crate::board::Samples;

use super::{
    compensation::SamplePathFilter,
    config::{BLOCK_LEN, SAMPLE_RATE_HZ},
    flags,
    handoff::{self, DESIGN_READY, EstimateBlock, LATEST_READ_RH_PCT, REPORT_QUEUE, RETUNE_REQUEST, ReportItem},
    ports::{CurrentSource, SampleBlock},
};

#[embassy_executor::task]
pub async fn sample_task(mut samples: Samples) {
    // Start-up only: sampling begins once the first design exists, so every reported
    // estimate comes from a real filter.
    let first = DESIGN_READY.wait().await;
    let mut filter = SamplePathFilter::new(&first);
    defmt::info!("sampling starts, design for {} %RH", first.rh_pct());

    samples.start();
    let mut first_sample: u32 = 0;
    let mut blocks: u32 = 0;
    let mut dropped_since_last = false;
    // One second of identical samples is no live front end (see ipmc_core::stuck).
    let mut stuck = StuckDetector::new(SAMPLE_RATE_HZ);
    let mut humidity = BlockHumidity::<f32>::new(&super::compensation::calibration(), reading_age_s());
    let mut error_bar = BlockError::<f32>::new(&super::compensation::error_table(), &ipmc_core::DesignConfig::firmware());
    // RH of the active or already requested design.
    let mut design_rh = first.rh_pct();
    // The first design is the start-up's fallback: the first reading replaces it even within
    // the retune threshold, so that RH_FALLBACK always clears.
    let mut on_fallback = handoff::conditions() & flags::RH_FALLBACK != 0;
    // Samples from the previous block's start to this one's (0 before the first: the strip
    // starts settled at the first reading).
    let mut since_last: u32 = 0;
    loop {
        let mut block = EstimateBlock {
            header: Header { first_sample, rh_pct: 0.0, rh_strip_pct: f32::NAN, rh_read_pct: 0.0, rel_err: f32::NAN, flags: 0 },
            base_est_m: [0.0; BLOCK_LEN],
        };
        let source_flags = match samples.read_block(&mut block.base_est_m).await {
            SampleBlock::Ready { flags, lost_samples } => {
                first_sample = first_sample.wrapping_add(lost_samples);
                block.header.first_sample = first_sample;
                // The strip dried or wetted through the lost samples too.
                since_last += lost_samples;
                flags
            }
            SampleBlock::End => break,
        };
        block.header.flags = source_flags | handoff::conditions();
        if stuck.observe(&block.base_est_m) {
            block.header.flags |= flags::STUCK;
        }

        if let Some(design) = DESIGN_READY.try_take() {
            filter.switch_to(&design);
            block.header.flags |= flags::RETUNED;
        }
        if filter.process(&mut block.base_est_m) {
            block.header.flags |= flags::BAD_SAMPLE;
        }
        block.header.rel_err = error_bar.block(filter.rh_pct(), &block.base_est_m);

        block.header.rh_read_pct = LATEST_READ_RH_PCT.load();
        // No reading yet: the first design is the humidity task's fallback, and stays.
        if let Some(now) = humidity.advance(block.header.rh_read_pct, span_s(since_last, SAMPLE_RATE_HZ)) {
            block.header.rh_strip_pct = humidity.strip_pct().unwrap_or(now.rh_pct);
            if now.clamped {
                block.header.flags |= flags::RH_CLAMPED;
            }
            if core::mem::take(&mut on_fallback) | asks_for_design(design_rh, now.rh_pct, filter.is_retuning()) {
                design_rh = now.rh_pct;
                RETUNE_REQUEST.signal(Request { rh_pct: now.rh_pct, fallback: false });
            }
        }
        since_last = BLOCK_LEN as u32;
        block.header.rh_pct = filter.rh_pct();
        if dropped_since_last {
            block.header.flags |= flags::REPORT_DROPPED;
        }
        dropped_since_last = REPORT_QUEUE.try_send(ReportItem::Block(block)).is_err();

        first_sample = first_sample.wrapping_add(BLOCK_LEN as u32);
        blocks += 1;
    }
    // End of a replay: waiting is fine now, nothing is sampled any more.
    REPORT_QUEUE.send(ReportItem::End { blocks }).await;
}
