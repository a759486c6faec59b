pub mod accuracy;
pub mod calib_export;
pub mod charging;
pub mod compensate;
pub mod design;
pub mod diagnose;
pub mod identify;
pub mod model;
pub mod monitor;
pub mod plot;
pub mod prove;
pub mod rh_sensitivity;
pub mod score;
pub mod simulate;
pub mod vs_exact;

pub use ipmc_recording::write_atomically;
