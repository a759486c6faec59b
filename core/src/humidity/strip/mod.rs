//! The strip's own hygrometer: the humidity it is at, fitted from its current's running spectrum
//! with the excitation unknown. The fit ([`fit`]) profiles out a smooth excitation ([`spline`])
//! and searches the calibration's model tabulated over the declared range ([`table`]), whose codes
//! are packed to fit the firmware's flash ([`packing`]; made once on the host, for build.rs and the
//! tool alike: `owned`); it gives an estimate or says why not
//! ([`estimate`]).

mod estimate;
mod fit;
#[cfg(feature = "std")]
mod owned;
mod packing;
mod spline;
mod table;
#[cfg(test)]
mod test_support;

pub use estimate::{Refusal, StripRh};
pub use fit::{
    AMBIGUITY_CHI2, MAX_MISFIT, MIN_INFORMATION_KEPT, MIN_SEGMENTS, SEARCH_TOL_PCT, SNR_MIN, TONE_Z, log_periodogram_variance, strip_rh,
};
#[cfg(feature = "std")]
pub use owned::OwnedTable;
pub use packing::{KEY_EVERY, PackedCodes, pack_codes};
pub use spline::{KNOT_SPACING_LN, MAX_BASIS};
pub use table::{GRID_STEP_PCT, MAX_GRID, ModelTable, TableScale, fill_table, table_nodes};
