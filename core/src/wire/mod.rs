//! The formats that cross the board's edge, each with its encoder and decoder in one place so
//! the two ends cannot drift apart: the binary stream of estimates the firmware sends
//! ([`stream`]), the replay file the QEMU board reads ([`replay`]) and the board's accelerometer
//! it replays beside it ([`accel_replay`]). Nothing here imports another room.

pub mod accel_replay;
pub mod replay;
pub mod stream;
