//! The formats that cross the board's edge, each with its encoder and decoder in one place so
//! the two ends cannot drift apart: the binary stream of estimates the firmware sends
//! ([`stream`]) and the replay file the QEMU board reads ([`replay`]). Nothing here imports
//! another room.

pub mod replay;
pub mod stream;
