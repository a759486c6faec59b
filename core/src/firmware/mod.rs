//! What the firmware decides, written without hardware so the host tests and the tool run the
//! same code: its operating point (the design it runs, when it retunes, its delay:
//! [`operating_point`]), its start-up ([`startup`]) and the detection of a stuck current input
//! ([`stuck`]).

pub mod operating_point;
pub mod startup;
pub mod stuck;
