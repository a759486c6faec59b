//! The firmware under QEMU: the formats it reads and writes (the replay, the board's
//! accelerometer made from a check, the stream, the recordings), one run of an ELF on a replay,
//! its estimates as EST.csv, and `cargo xtask qemu`. The formats are the bottom; `run` uses them,
//! `est` writes what a run gave, `command` uses all.

pub mod accel;
mod check;
mod command;
mod est;
pub mod recording;
pub mod replay;
mod run;
pub mod stream;

pub use command::{command, replay_recording};
pub use est::{band_of, write_est_csv};
pub use run::{FIRMWARE_FS_HZ, Replayed, flags, run_replay, run_replay_to};
