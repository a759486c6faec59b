//! Where the stream is read from: a serial port, a captured stream file, or stdin (`-`).

use anyhow::{Context, Result};
use std::fs::File;
use std::io::Read;
use std::time::Duration;

/// Opens `port` (a serial port at `baud`, a file, or `-` for stdin) for reading.
pub fn open(port: &str, baud: u32) -> Result<Box<dyn Read>> {
    if port == "-" {
        return Ok(Box::new(std::io::stdin().lock()));
    }
    if !is_serial_device(port) {
        let f = File::open(port).with_context(|| format!("cannot open {port}"))?;
        return Ok(Box::new(f));
    }
    let p = serialport::new(port, baud)
        .timeout(Duration::from_millis(200))
        .open()
        .with_context(|| format!("cannot open serial port {port} at {baud} Bd"))?;
    Ok(Box::new(p))
}

/// Regular files and pipes are read as captured streams; character devices (and names that
/// are not files at all, such as COM3) go through the serial port driver.
fn is_serial_device(port: &str) -> bool {
    match std::fs::metadata(port) {
        #[cfg(unix)]
        Ok(m) => std::os::unix::fs::FileTypeExt::is_char_device(&m.file_type()),
        #[cfg(not(unix))]
        Ok(_) => false,
        Err(_) => true,
    }
}
