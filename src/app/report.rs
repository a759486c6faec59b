//! Reporting: every block goes out as a stream frame; a defmt status line goes out about
//! once a second. At the end of a replay, tells the board to finish.

use crate::board::{self, Stream};

use super::{
    config::LOG_EVERY_BLOCKS,
    handoff::{REPORT_QUEUE, ReportItem},
    ports::StreamSink,
    stream_frame::{self, MAX_FRAME_LEN},
};

#[embassy_executor::task]
pub async fn report_task(mut stream: Stream) {
    let mut frame = [0u8; MAX_FRAME_LEN];
    let mut reported: u32 = 0;
    loop {
        match REPORT_QUEUE.receive().await {
            ReportItem::Block(block) => {
                let n = stream_frame::encode(&block, &mut frame);
                stream.write_all(&frame[..n]).await;
                if reported % LOG_EVERY_BLOCKS == 0 {
                    defmt::info!(
                        "sample {}: base {} m, RH {} %, flags {=u16:#x}",
                        block.first_sample,
                        block.base_est_m[0],
                        block.rh_pct,
                        block.flags
                    );
                }
                reported += 1;
            }
            ReportItem::End { blocks } => {
                defmt::info!("input ended: {} blocks processed, {} reported", blocks, reported);
                board::finish(blocks == reported);
            }
        }
    }
}
