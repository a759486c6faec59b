//! The simulator of ipmc-sense: simulated recordings in the interchange formats, from a
//! calibration, a session ([`session::Session`]) and a physics ([`physics::Physics`]: the seam
//! where an effect the exact model lacks can be injected). Deterministic for a given seed: the
//! bundled recordings, `ipmc prove`'s cases and the tests are what a seed makes.
//!
//! Four rooms, each importing only those before it:
//! - [`session`]: the session file, what a recording is asked to be, and `ipmc simulate-sweep`'s
//!   two-level ramp as a session ([`sweep`]);
//! - `world`: what is simulated: the physics seam ([`physics`]), the sample and a strip's
//!   identity ([`Strip`]), the humidity bench and the room;
//! - `recordings`: how a recording is made: [`simulate`] and the [`Recording`] it makes (a
//!   frequency response, a time series or charging recordings), and field mode, a strip in
//!   service ([`field`]);
//! - `proof`: the effects `ipmc prove` conceals ([`effects`]), its cases ([`concealed`]) and
//!   their follow-ups ([`followup`]).
//!
//! Its random numbers are the fit library's ([`random`]).

mod proof;
mod recordings;
pub mod session;
mod world;

pub use ipmc_fit::random;
pub use proof::{concealed, effects, followup, lookalike};
pub use recordings::{Recording, field, simulate};
pub use session::sweep;
pub use world::sample::{STRIP_KNOT_PCT, Strip};
pub use world::{aging, physics};
