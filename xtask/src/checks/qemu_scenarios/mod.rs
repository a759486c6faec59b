//! The firmware's QEMU scenarios, steps of `cargo xtask test`: replays through the QEMU build
//! (synthetic, faulty, recordings, a check with the board's accelerometer), each checking what
//! the firmware must do, and the host ↔ QEMU equivalence. `harness` is what they share.

mod check;
mod equivalence;
mod harness;
mod recordings;
mod synthetic;

pub use check::qemu_replay_check;
pub use equivalence::{
    qemu_host_equivalence, qemu_host_equivalence_fused, qemu_host_equivalence_low_latency, qemu_host_equivalence_with_departures,
    qemu_host_equivalence_with_humidity_path, qemu_long_run,
};
pub use recordings::{qemu_replay_bundled, qemu_replay_idealized_sweep};
pub use synthetic::{
    qemu_replay_adc_overrun, qemu_replay_counts_and_retunes, qemu_replay_faults, qemu_replay_humidity_step_without_glitch,
    qemu_replay_no_new_humidity, qemu_replay_no_receiver, qemu_replay_one_bad_sample, qemu_replay_sensor_faults,
};
