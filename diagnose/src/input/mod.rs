//! The recordings coming in: a strip's files, primaries and follow-ups read and checked
//! together, and the dataset every later stage reads them as (levels, humidity histories,
//! bursts, references).

pub mod data;
pub mod strip_files;
