//! The simulator's deterministic random numbers are the fit library's ([`ipmc_fit::random`]).

pub use ipmc_fit::random::SplitMix64;
