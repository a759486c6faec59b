//! The estimates as a recording-format CSV (the estimate file `ipmc compensate` writes, with the
//! strip's own hygrometer's columns), and a check's samples as a check recording (recording
//! format §5: the current, the humidity as read and the board's accelerometer).

use super::decode::{CheckSample, Sample, WindowSample};
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

/// Creates the check recording `path` (recording format §5) with its metadata and header line.
pub fn create_check(path: &Path, fs_hz: u32) -> Result<BufWriter<File>> {
    let f = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = BufWriter::new(f);
    writeln!(w, "# fs_hz={fs_hz}")?;
    writeln!(w, "# format=time_series")?;
    writeln!(w, "# accel=the board's LSM6DSL on the strip's base, resampled onto the ADC's clock by the firmware [m/s^2]")?;
    writeln!(w, "t_s,current_a,rh_pct,accel_mps2")?;
    Ok(w)
}

/// One sample of a check as a row, the humidity as the sensor read it; a sample without the
/// accelerometer's value or a reading (none yet, or the resampler had no whole block) is no
/// check's and is left out: `false`.
pub fn write_check_sample(w: &mut impl Write, c: &CheckSample) -> std::io::Result<bool> {
    if !(c.accel_mps2.is_finite() && c.current_a.is_finite() && c.rh_read_pct.is_finite()) {
        return Ok(false);
    }
    writeln!(w, "{},{:e},{},{:e}", c.t_s, c.current_a, c.rh_read_pct, c.accel_mps2)?;
    Ok(true)
}

/// Creates the table of the running error's windows `path`: per window its end, the error the
/// device measured against the accelerometer and the error stated, both in percent, and the flag.
pub fn create_windows(path: &Path) -> Result<BufWriter<File>> {
    let f = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut w = BufWriter::new(f);
    writeln!(
        w,
        "# the estimate's error in band measured on the device against its accelerometer, per window (ipmc_core::firmware::running_error)"
    )?;
    writeln!(w, "t_end_s,measured_pct,stated_pct,calibration_stale")?;
    Ok(w)
}

/// One window as a row.
pub fn write_window(w: &mut impl Write, s: &WindowSample) -> std::io::Result<()> {
    writeln!(w, "{},{},{},{}", s.t_end_s, 100.0 * s.measured, 100.0 * s.stated, u8::from(s.stale))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The rows a check recording gets are read back by the one reader as a check, value for value.
    #[test]
    fn a_checks_rows_read_back_as_a_check() {
        let dir = std::env::temp_dir().join(format!("ipmc-monitor-check-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("CHECK.csv");
        let sample = |k: u32, accel_mps2: f32| CheckSample {
            t_s: k as f64 / 2000.0,
            current_a: k as f32 * -1.25e-7,
            rh_read_pct: 63.75,
            accel_mps2,
        };
        let mut w = create_check(&path, 2000).unwrap();
        let mut kept = 0;
        for k in 0..4 {
            kept += usize::from(write_check_sample(&mut w, &sample(k, 0.1 + k as f32)).unwrap());
        }
        assert!(!write_check_sample(&mut w, &sample(4, f32::NAN)).unwrap(), "no acceleration: no row");
        assert!(!write_check_sample(&mut w, &CheckSample { rh_read_pct: f32::NAN, ..sample(5, 1.0) }).unwrap(), "no reading: no row");
        drop(w);
        let (ts, _) = <ipmc_recording::TimeSeries as ipmc_recording::Format>::read(&path).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        assert_eq!(kept, 4);
        assert!(ts.is_check() && ts.base_m.is_none());
        assert_eq!(ts.fs_hz, 2000.0);
        // Each value as the f32 it was: the row holds its shortest decimal form.
        let as_f32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<_>>();
        assert_eq!(as_f32(&ts.current_a), (0..4).map(|k| k as f32 * -1.25e-7).collect::<Vec<_>>());
        assert_eq!(as_f32(ts.accel_mps2.as_deref().unwrap()), (0..4).map(|k| 0.1 + k as f32).collect::<Vec<_>>());
        assert!(ts.rh_pct.iter().all(|&r| r == 63.75));
    }
}
