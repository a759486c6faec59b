//! `ipmc compensate`'s work around the chain (`crate::chain`): the current's noise it states its
//! error with (`current_noise`) and the humidity's (`humidity_uncertainty`), short bursts looped (`looping`), the estimate file written
//! (`estimate_file`) and the figures printed of it (`figures`).

pub mod current_noise;
pub mod estimate_file;
pub mod figures;
pub mod humidity_uncertainty;
pub mod looping;

pub use current_noise::current_noise;
pub use estimate_file::estimate_file;
pub use figures::print_figures;
pub use humidity_uncertainty::humidity_uncertainty;
pub use looping::loop_if_short;
