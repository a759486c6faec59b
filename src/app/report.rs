//! Reporting: every block goes out as a stream frame; a defmt status line goes out about
//! once a second. At the end of a replay, tells the board to finish.

use ipmc_core::wire::stream::{self, Check, Header};

use crate::board::{self, Stream};

use super::handoff::{CHECKS, REPORT_QUEUE, ReportItem};
use crate::contract::{
    config::{BLOCK_LEN, LOG_EVERY_BLOCKS},
    flags::REPORT_DROPPED,
    sources::StreamSink,
};

/// The wire format (documented in ipmc-core's `wire::stream` module) carries at most 255 estimates.
const _: () = assert!(BLOCK_LEN <= stream::MAX_ESTIMATES);
const MAX_FRAME_LEN: usize = stream::max_frame_len(BLOCK_LEN);

#[embassy_executor::task]
pub async fn report_task(mut stream: Stream) {
    let mut frame = [0u8; MAX_FRAME_LEN];
    let mut reported: u32 = 0;
    let mut frames_dropped: u32 = 0;
    let mut dropped_since_last = false;
    loop {
        match REPORT_QUEUE.receive().await {
            ReportItem::Block(block) => {
                // The receiver learns of frames the stream lost from the next frame that arrives.
                let flags = block.header.flags | if dropped_since_last { REPORT_DROPPED } else { 0 };
                let header = Header { flags, ..block.header };
                let sent = match encode(&header, &block.base_est_m, block.has_check, &mut frame) {
                    Ok(n) => stream.write_all(frame.get(..n).unwrap_or(&[])).await.is_ok(),
                    // Cannot happen with the buffer sized above; losing a frame beats stopping.
                    Err(_) => {
                        defmt::error!("stream frame not encoded (buffer too small)");
                        false
                    }
                };
                dropped_since_last = !sent;
                if !sent {
                    frames_dropped = frames_dropped.wrapping_add(1);
                }
                if reported.is_multiple_of(LOG_EVERY_BLOCKS) {
                    defmt::info!(
                        "sample {}: base {} m ± {} %, RH {} % (design; strip {} %, read {} %), flags {=u16:#x}, {} frames dropped by the stream",
                        block.header.first_sample,
                        block.base_est_m[0],
                        100.0 * block.header.rel_err,
                        block.header.rh_pct,
                        block.header.rh_strip_pct,
                        block.header.rh_read_pct,
                        flags,
                        frames_dropped
                    );
                }
                reported += 1;
            }
            ReportItem::End { blocks } => {
                defmt::info!(
                    "input ended: {} blocks processed, {} reported, {} frames dropped by the stream",
                    blocks,
                    reported,
                    frames_dropped
                );
                board::finish(blocks == reported);
            }
        }
    }
}

/// The block's frame into `frame`, with its check where it has one (taken from `CHECKS` here, so
/// that the check is not held across the stream's wait: the task's state would keep its 264 B).
#[inline(never)]
fn encode(header: &Header, base_est_m: &[f32; BLOCK_LEN], has_check: bool, frame: &mut [u8]) -> Result<usize, stream::EncodeError> {
    let held = if has_check { CHECKS.try_receive().ok() } else { None };
    let check =
        held.as_ref().map(|c| Check { first_sample: c.first_sample, current_a: &c.current_a, accel_mps2: &c.accel_mps2, window: c.window });
    stream::encode(header, base_est_m, check, frame)
}
