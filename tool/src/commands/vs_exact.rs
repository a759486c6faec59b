//! `ipmc vs-exact`: what the causal f32 chain loses to its implementation, level by level: per
//! burst of a periodic-excitation recording, the firmware's chain and the exact band-limited
//! inverse of the same nominal model scored alike in the design band, their ratio, and beside
//! them the chain with the robust inverse (`--inverse robust` of `compensate`) and its non-causal
//! ideal (`ipmc_tool::exact::against_chain`).

use anyhow::{Result, bail};
use ipmc_tool::chain::rh_uncertainty;
use ipmc_tool::exact::against_chain::{Level, levels};
use ipmc_tool::scoring::{SETTLE_S, Scoring};
use ipmc_tool::support::input::read_time_series;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Time-series recording of periodic excitation (t_s, current_a, rh_pct, base_m).
    input: PathBuf,
    /// Period of the excitation [s]; each burst must hold at least one whole period.
    #[arg(long, default_value_t = 1.0)]
    period_s: f64,
    /// Seconds scored per level, after the chain's settling; a whole number of bursts' worth of
    /// periods, so that the scored stretch is periodic and its band has no leakage.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Calibration: `default`, `paper`, or a TOML file (the nominal model of the recording).
    #[arg(long)]
    calib: Option<String>,
    /// Standard uncertainty of the humidity reading [%RH]: the expected error and the robust
    /// inverses; by default as for `ipmc compensate`.
    #[arg(long)]
    rh_uncertainty: Option<f64>,
    /// Fail (exit status 1) when any level's ratio exceeds this.
    #[arg(long)]
    max_ratio: Option<f64>,
}

pub fn run(a: Args) -> Result<()> {
    let calib = ipmc_tool::support::calibration_source::load(a.calib.as_deref())?;
    let ts = read_time_series(&a.input)?;
    let levels = levels(&calib, &ts, a.period_s, a.seconds, rh_uncertainty(&calib, a.rh_uncertainty))?;
    let scoring = Scoring::new(&calib.band, ts.fs_hz, Some(a.period_s))?;
    println!(
        "{}: error in {}–{} Hz {}, each burst repeated to at least {SETTLE_S} s + {} s, all but the first {:.2} s (the settling and the \
         band filter's start-up) scored; the columns below and above the band: DFT lines of all but the first {SETTLE_S} s",
        a.input.display(),
        calib.band.low_hz,
        calib.band.high_hz,
        scoring.describe(),
        a.seconds,
        scoring.skip() as f64 / ts.fs_hz
    );
    println!(
        "{:>8} {:>10} {:>10} {:>7} {:>10} {:>9}   {:>12}   {:>13} {:>13}",
        "RH %", "causal %", "exact %", "ratio", "robust %", "ideal %", "est/truth", "causal .5Hz-lo", "causal hi-Nyq"
    );
    let mut worst: f64 = 0.0;
    for l in &levels {
        let ratio = l.causal / l.exact;
        worst = worst.max(ratio);
        println!(
            "{:>8.2} {:>10.3} {:>10.3} {:>7.3} {:>10.3} {:>9.3}   {:>12.3}   {:>13.3} {:>13.3}",
            l.rh_pct,
            l.causal * 100.0,
            l.exact * 100.0,
            ratio,
            l.robust * 100.0,
            l.ideal_robust * 100.0,
            l.estimate_over_truth,
            l.causal_below_band * 100.0,
            l.causal_above_band * 100.0
        );
    }
    let rms = |f: fn(&Level) -> f64| (levels.iter().map(|l| f(l).powi(2)).sum::<f64>() / levels.len() as f64).sqrt() * 100.0;
    println!(
        "rms over the levels: causal {:.2} %, exact {:.2} %, robust {:.2} %, ideal robust {:.2} %",
        rms(|l| l.causal),
        rms(|l| l.exact),
        rms(|l| l.robust),
        rms(|l| l.ideal_robust)
    );
    println!("worst ratio {worst:.3}");
    if let Some(max) = a.max_ratio
        && worst > max
    {
        bail!("worst ratio {worst:.3} exceeds {max}");
    }
    Ok(())
}
