//! What the firmware decides, written without hardware so the host tests and the tool run the
//! same code: what one block of the sample path comes to ([`block_step`], the device's and the
//! host's replay's one step), its operating point (the design it runs, when it retunes, its delay:
//! [`operating_point`]), its start-up ([`startup`]), the detection of a stuck current input
//! ([`stuck`]), what the sample path does while a block does not come ([`block_wait`]) and the
//! count of samples an overrun lost ([`lost_samples`]), the estimate's error measured against
//! the board's accelerometer ([`running_error`]) and the test that calls a calibration stale
//! ([`calibration_stale`]); and [`device_calls`], its
//! per-sample and retune calls made for f32 in this crate, at its opt-level.

pub mod block_step;
pub mod block_wait;
pub mod calibration_stale;
pub mod device_calls;
pub mod lost_samples;
pub mod operating_point;
pub mod running_error;
pub mod screen;
pub mod startup;
pub mod stuck;
