//! Application: the tasks, identical for every board. Sources come in through the board's
//! implementations of `contract::sources`, the compensation comes from ipmc-core through `compensation`,
//! results leave through `report`.

pub mod compensation;
pub mod handoff;
pub mod humidity;
pub mod hygrometer;
pub mod report;
pub mod retune;
pub mod sample_path;
