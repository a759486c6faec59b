//! Reading recordings for the commands: the one reader is the `ipmc-recording` crate; here its
//! warnings (unknown columns…) are shown to the user on stderr.

use ipmc_recording::{Error, Warning};

/// The value of a recording reader, its warnings printed on stderr.
pub fn checked<T>(read: Result<(T, Vec<Warning>), Error>) -> anyhow::Result<T> {
    let (value, warnings) = read?;
    for w in warnings {
        eprintln!("warning: {w}");
    }
    Ok(value)
}
