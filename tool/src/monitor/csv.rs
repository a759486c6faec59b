//! The estimates as a recording-format CSV (the estimate file `ipmc compensate` writes, with the
//! strip's own hygrometer's columns).

use super::decode::Sample;
use anyhow::{Context, Result};
use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::Path;

/// Creates `path` with its `# fs_hz=` metadata and header line.
pub fn create(path: &Path, fs_hz: u32) -> Result<BufWriter<File>> {
    let f = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = BufWriter::new(f);
    writeln!(w, "# fs_hz={fs_hz}")?;
    writeln!(w, "t_s,base_est_m,rh_pct,rh_strip_pct,rh_read_pct,rel_err,flags,{}", ipmc_recording::HYGROMETER_COLUMNS.join(","))?;
    Ok(w)
}

/// One estimate as a row.
pub fn write_sample(w: &mut impl Write, s: &Sample) -> std::io::Result<()> {
    let h = &s.hygrometer;
    writeln!(
        w,
        "{},{:e},{},{},{},{:e},{},{},{},{},{},{}",
        s.t_s,
        s.base_est_m,
        s.rh_pct,
        s.rh_strip_pct,
        s.rh_read_pct,
        s.rel_err,
        s.flags,
        h.read_sd_pct,
        h.own_pct,
        h.own_sd_pct,
        h.fused_pct,
        h.fused_sd_pct
    )
}
