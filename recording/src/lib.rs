//! The recording interchange formats of ipmc-sense (`shared/recording-format.md`): the one reader
//! and writer every host command and xtask use.
//!
//! - [`FrequencyResponse`]: one row per (humidity level, frequency), grouped into [`Level`]s.
//! - [`TimeSeries`]: uniformly sampled bursts (`# fs_hz`).
//! - [`Charging`]: a constant-voltage charging current (`# voltage_v`).
//! - [`HumidityReference`]: the humidity sensor read at references of known humidity.
//! - [`Followup`]: what makes a recording a follow-up (`# followup=`, `# strip=`).
//! - [`stated_setpoints`]: the chamber's setpoints a session states (`# rh_levels=`).
//! - [`Estimates`]: the base-motion estimates `ipmc compensate` and the firmware write.
//! - [`looping`]: short bursts of a periodic excitation repeated by whole periods.
//! - [`Table`]: the common layer under them (comments, metadata, columns by name, positions).
//!
//! Reading never panics on outside data: a bad row is an [`Error`] naming the file, line, column
//! and what was expected. Unknown columns are returned as [`Warning`]s (the library prints nothing).

mod charging;
mod error;
mod estimates;
mod followup;
mod frequency_response;
mod humidity_reference;
pub mod looping;
mod metadata;
mod output;
mod setpoints;
mod table;
mod time_series;

pub use charging::Charging;
pub use error::{Error, FieldRef, Warning};
pub use estimates::{Estimates, HYGROMETER_COLUMNS, Hygrometer as HygrometerColumns};
pub use followup::{Followup, Protocol};
pub use frequency_response::{FrPoint, FrequencyResponse, LEVEL_SCATTER_PCT, Level, Response, unwrap_degrees};
pub use humidity_reference::HumidityReference;
pub use metadata::Metadata;
pub use output::{write_atomically, write_atomically_with};
pub use setpoints::{SETPOINTS_KEY, SetpointForm, setpoints_text, stated_setpoints};
pub use table::{Rule, Table};
pub use time_series::{NumberFormat, TimeSeries};

/// A recording format: how it is read from a [`Table`]; reading a file or a text follows.
/// Every reader returns the warnings (unknown columns…) for the caller to show.
pub trait Format: Sized {
    fn from_table(t: &Table) -> Result<(Self, Vec<Warning>), Error>;

    fn read(path: &std::path::Path) -> Result<(Self, Vec<Warning>), Error> {
        Self::from_table(&Table::read(path)?)
    }

    /// `source` names the text in errors.
    fn parse(source: &str, text: &str) -> Result<(Self, Vec<Warning>), Error> {
        Self::from_table(&Table::parse(source, text)?)
    }
}

/// Reads a whole file as text; the error names the file (and the line of invalid UTF-8).
fn read_text(path: &std::path::Path) -> Result<String, Error> {
    let source = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|e| Error::file(&source, format!("cannot read: {e}")))?;
    match String::from_utf8(bytes) {
        Ok(s) => Ok(s),
        Err(e) => {
            let valid = &e.as_bytes()[..e.utf8_error().valid_up_to()];
            let line = valid.iter().filter(|&&b| b == b'\n').count() + 1;
            let col = valid.rsplit(|&b| b == b'\n').next().map_or(0, |l| String::from_utf8_lossy(l).chars().count()) + 1;
            Err(Error {
                source,
                line: Some(line),
                field: Some(FieldRef { name: None, index: None, char: Some(col) }),
                message: "not UTF-8 text".into(),
            })
        }
    }
}
