//! The diagnosis's figures and report: the library (`ipmc-diagnose`) decides and reports, the
//! tool draws (`figures`) and writes the report and what follows from it (`report`), so that
//! plotting stays out of the library.

pub mod figures;
pub mod report;
