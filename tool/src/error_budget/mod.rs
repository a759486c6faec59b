//! The error budget: what an estimate's stated error is made of and where it comes from. The
//! split of the stated 1σ into the calibration's, the humidity's and the noise's parts per
//! humidity (`limits`), the humidity reading's uncertainty and who states it
//! (`reading_uncertainty`), the current's noise measured where no periods can be differenced
//! (`noise_floor`), and the calibrated range's ends that rest on one reading (`range_edges`).

pub mod limits;
pub mod noise_floor;
pub mod range_edges;
pub mod reading_uncertainty;
