//! The humidity the designs are made at, other than the reading: the strip as its own
//! hygrometer over a recording (`hygrometer`, what the fused humidity is), and a bench session's
//! bursts placed at their chamber's setpoints (`chamber`).

pub mod chamber;
pub mod hygrometer;
