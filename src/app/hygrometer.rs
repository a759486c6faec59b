//! The strip's own hygrometer's fit: takes the spectrum the sample path hands over at most once a
//! second, fits the strip's humidity to it in thread mode (beside the retunes, below every
//! interrupt), and hands the result back for the sample path's next block.

use super::{
    compensation,
    handoff::{FIT_REQUEST, FIT_RESULT},
};

#[embassy_executor::task]
pub async fn fit_task() {
    loop {
        let snapshot = FIT_REQUEST.wait().await;
        FIT_RESULT.signal(compensation::fit(&snapshot));
    }
}
