//! The proof's support: `ipmc prove` conceals one effect the exact model lacks in a session
//! with everything a real bench has, and asks the diagnosis to name it. Here are the effects,
//! drawn at a magnitude ([`effects`]), the cases made of them ([`concealed`]), the look-alike
//! family of an RC line and an amplifier pole of the same lag ([`lookalike`]) and the follow-up
//! measurements a case's strip can be given ([`followup`]).

pub mod concealed;
pub mod effects;
pub mod followup;
pub mod lookalike;
