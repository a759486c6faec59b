//! Status bits carried with every block of estimates (stream frames, EST.csv `flags`). They are
//! part of the wire format, so they are defined next to it, in ipmc-core's `wire::stream::flags`.
#![allow(unused_imports)] // each board raises a subset of the bits

pub use ipmc_core::wire::stream::flags::*;
