//! `ipmc score`: an estimate's error against the true base motion of the recording it came
//! from, by the one scoring every command uses (`ipmc_tool::scoring`; `cargo xtask qemu` scores the
//! firmware's estimates with this command).

use anyhow::{Result, bail};
use ipmc_tool::scoring::accelerometer::DeviceMeasure;
use ipmc_tool::scoring::estimate_file::{Options, Scored, score, share};
use ipmc_tool::scoring::stale_chance::undecided;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The recording (time-series format) with the true `base_m`.
    recording: PathBuf,
    /// The estimate (`t_s,base_est_m,…`, as `ipmc compensate` and `cargo xtask qemu` write it).
    estimate: PathBuf,
    /// The inverse's preview [ms], by which the true base is shifted before it goes through the
    /// band filter; by default the design's (`max_delay_s`).
    #[arg(long)]
    preview_ms: Option<f64>,
    /// The band scored in [Hz], as `LOW-HIGH`; by default the estimate file's `band_hz`, else
    /// 10–150 Hz.
    #[arg(long)]
    band_hz: Option<String>,
    /// One JSON line `{"band_error": …, "estimate_over_truth": …, "band_hz": […]}` (fractions)
    /// for scripts (with --coverage also `coverage`, `windows`, `levels_covered`, `levels`).
    #[arg(long)]
    json: bool,
    /// Also how often the estimate's stated 1σ (its `rel_err` column) contains the actual
    /// error: per burst (expected against actual) and over windows of about this many seconds
    /// (whole periods where the recording states its period).
    #[arg(long, value_name = "WINDOW_S")]
    coverage: Option<f64>,
    /// With --coverage, also every window: its actual error and stated 1σ (an hour of service
    /// minute by minute, say).
    #[arg(long, requires = "coverage")]
    per_window: bool,
}

pub fn run(a: Args) -> Result<()> {
    let options = Options { preview_ms: a.preview_ms, band_hz: a.band_hz.as_deref(), coverage_window_s: a.coverage };
    let scored = score(&a.recording, &a.estimate, &options)?;
    let Scored { loaded, coverage, score } = &scored;
    let (ts, scoring) = (&loaded.ts, &loaded.scoring);
    if let (Some(c), false) = (coverage, a.json) {
        println!("  RH [%]   expected 1σ [%]   actual [%]   windows within");
        for b in &c.bursts {
            let inside = b.windows.iter().filter(|w| w.covered()).count();
            println!(
                "  {:6.2}   {:15.3}   {:10.3}   {inside}/{}",
                b.rh_pct,
                100.0 * b.whole.stated,
                100.0 * b.whole.actual,
                b.windows.len()
            );
            if a.per_window {
                for (k, w) in b.windows.iter().enumerate() {
                    println!("    window {k:4}   {:15.3}   {:10.3}", 100.0 * w.stated, 100.0 * w.actual);
                }
            }
        }
        let (w, b) = (c.windows_covered, c.bursts_covered);
        let window = match scoring.period {
            Some(p) => format!("{} s (whole periods)", ((c.window_s * ts.fs_hz / p as f64).round().max(1.0)) * p as f64 / ts.fs_hz),
            None => format!("{} s (not whole periods)", c.window_s),
        };
        println!(
            "coverage: the actual error is within the stated 1σ in {} of {} windows of {window} ({:.1} %), {} of {} bursts",
            w.0,
            w.1,
            100.0 * share(w),
            b.0,
            b.1
        );
    }
    let Some(figures) = scored.figures() else {
        bail!("{}", ipmc_tool::scoring::nothing_scored(&a.recording, ts, scoring));
    };
    if a.json {
        let mut j = serde_json::json!({
            "band_error": figures.band_error,
            "rms_over_bursts": figures.rms_over_bursts,
            "per_burst": figures.per_burst,
            "estimate_over_truth": figures.estimate_over_truth,
            "band_hz": figures.band_hz,
            "bursts": figures.bursts,
            "whole_periods": figures.whole_periods,
        });
        if let Some(c) = figures.coverage {
            j["coverage"] = c.coverage.into();
            j["windows"] = c.windows.into();
            j["levels_covered"] = c.levels_covered.into();
            j["levels"] = c.levels.into();
        }
        println!("{j}")
    } else {
        println!("{}", ipmc_tool::scoring::line(scoring, score));
    }
    if let (Some(accel), None) = (&ts.accel_mps2, &ts.base_m) {
        let rel_err = loaded.file.rel_err.as_deref();
        match DeviceMeasure::run(scoring, accel, &loaded.file.base_est_m, rel_err, &ts.bursts()) {
            Some(d) if !d.windows.is_empty() => {
                let last = d.windows.last().expect("not empty");
                let stale = d.first_stale().map_or("never".to_string(), |k| format!("from its window {k} on"));
                println!(
                    "on the device (firmware::running_error, f32, {} windows of 5 s): {:.2} % pooled (score: {:.2} %), stated 1σ {:.2} %; \
                     its chain's delay {:.3} ms and rate {:+.1} ppm at its last window; CALIBRATION_STALE {stale}",
                    d.windows.len(),
                    100.0 * d.pooled(),
                    100.0 * score.pooled.error(),
                    100.0 * d.stated(),
                    1e3 * last.delay_s,
                    1e6 * last.rate
                );
                if let Some(line) = undecided(&d.stale_test(), last.stale) {
                    println!("  {line}");
                }
            }
            _ => println!("on the device: no window measured (a check shorter than the device's settling)"),
        }
    }
    Ok(())
}
