//! The diagnosis's figures: the library (`ipmc-diagnose`) decides and reports, the tool draws,
//! so that plotting stays out of the library.

pub mod figures;
