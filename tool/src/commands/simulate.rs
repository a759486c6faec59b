//! `ipmc simulate`: a recording in the interchange format from a calibration and a session file
//! (data/sessions/*.toml): frequency response, time series or charging, humidity levels in any order,
//! noise, deterministic for a seed. The work is done by [`crate::simulator`].
//!
//! `ipmc simulate-sweep`: the two-level humidity ramp of a time series with its own flags, made
//! by the same simulator (it made the bundled data/sweep-40-80.csv, which it still reproduces
//! byte for byte): one continuous burst during which the humidity ramps linearly, multisine
//! base motion (`tones` log-spaced tones over [`f_lo`, `f_hi`], equal amplitudes summing to
//! `amplitude_m`, random phases), the model's quasi-static current, numbers written compactly.

use crate::calibration_source;
use crate::commands::write_atomically;
use crate::simulator::physics::ExactModel;
use crate::simulator::session::{Frequencies, Humidity, Kind, Noise, Session, TimeSeriesPlan};
use crate::simulator::{Recording, simulate};
use anyhow::{Context, Result};
use ipmc_recording::Metadata;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Session file (TOML): kind, humidity levels and their order, frequencies or multisine,
    /// noise, seed. Examples: data/sessions/*.toml.
    #[arg(long)]
    session: PathBuf,
    /// Calibration of the simulated sample: `default`, `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
    /// Output recording (CSV in the interchange format of the session's kind).
    #[arg(long)]
    out: PathBuf,
}

pub fn run(a: Args) -> Result<()> {
    let calib = calibration_source::load(a.calib.as_deref())?;
    let text = std::fs::read_to_string(&a.session).with_context(|| format!("cannot read session {}", a.session.display()))?;
    let session = Session::parse(&a.session, &text)?;
    let mut metadata = Metadata::default();
    metadata.set("generator", format!("ipmc simulate session={} seed={}", a.session.display(), session.seed));
    metadata.set("calib", a.calib.as_deref().unwrap_or("default"));
    let spin = crate::progress::spinner("simulating");
    let rec = simulate(&calib, &session, &ExactModel, metadata)?;
    spin.finish_and_clear();
    let files = rec.files(&a.out)?;
    for (path, text) in &files {
        write_atomically(path, text.as_bytes())?;
    }
    let names: Vec<String> = files.iter().map(|f| f.0.display().to_string()).collect();
    eprintln!("wrote {} to {}", rec.summary(), names.join(", "));
    Ok(())
}

#[derive(clap::Args)]
pub struct SweepArgs {
    /// Output recording (CSV, time-series format).
    #[arg(long)]
    out: PathBuf,
    /// Duration [s].
    #[arg(long, default_value_t = 20.0)]
    seconds: f64,
    /// Sample rate [Hz].
    #[arg(long, default_value_t = 2000.0)]
    fs: f64,
    /// Relative humidity at the start of the run [%].
    #[arg(long, default_value_t = 40.0)]
    rh_from: f64,
    /// Relative humidity at the end of the run [%].
    #[arg(long, default_value_t = 80.0)]
    rh_to: f64,
    /// Seed of the tone phases (and of the noise).
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Standard deviation of white Gaussian noise added to the current [A].
    #[arg(long, default_value_t = 0.0)]
    noise_a: f64,
    /// Number of tones.
    #[arg(long, default_value_t = 8)]
    tones: usize,
    /// Lowest tone [Hz].
    #[arg(long, default_value_t = 12.0)]
    f_lo: f64,
    /// Highest tone [Hz].
    #[arg(long, default_value_t = 140.0)]
    f_hi: f64,
    /// Sum of the tone amplitudes [m].
    #[arg(long, default_value_t = 20e-6)]
    amplitude_m: f64,
    /// Calibration of the simulated sample: `default`, `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
}

/// The sweep as a session: one time-series ramp between two levels, current noise only.
fn sweep_session(a: &SweepArgs) -> Session {
    Session {
        kind: Kind::TimeSeries,
        seed: a.seed,
        temp_c: None,
        temp_swing_k: 0.0,
        temp_read_error_k: 0.0,
        humidity: Humidity { levels_pct: vec![a.rh_from, a.rh_to], ..Humidity::default() },
        sample: Default::default(),
        frequencies: None::<Frequencies>,
        time_series: Some(TimeSeriesPlan {
            fs_hz: a.fs,
            burst_s: a.seconds,
            ramp: true,
            tones: a.tones,
            from_hz: a.f_lo,
            to_hz: a.f_hi,
            amplitude_m: a.amplitude_m,
            record_tip: false,
            compact: true,
            tone_grid_hz: None,
        }),
        charging: None,
        noise: Noise { current_a: a.noise_a, ..Noise::default() },
    }
}

pub fn run_sweep(a: SweepArgs) -> Result<()> {
    let session = sweep_session(&a);
    session.validate().context("simulate-sweep")?;
    let mut metadata = Metadata::default();
    metadata.set(
        "generator",
        format!("ipmc simulate-sweep seed={} rh_from={} rh_to={} seconds={} noise_a={}", a.seed, a.rh_from, a.rh_to, a.seconds, a.noise_a),
    );
    if let Some(c) = &a.calib {
        metadata.set("calib", c);
    }
    let spin = crate::progress::spinner("simulating");
    let rec = simulate(&calibration_source::load(a.calib.as_deref())?, &session, &ExactModel, metadata)?;
    spin.finish_and_clear();
    for (path, text) in rec.files(&a.out)? {
        write_atomically(&path, text.as_bytes())?;
    }
    if let Recording::TimeSeries(ts, _) = &rec {
        eprintln!(
            "wrote {} samples ({} s at {} Hz, RH {} → {} %, {} tones {:.1}–{:.1} Hz) to {}",
            ts.len(),
            a.seconds,
            a.fs,
            a.rh_from,
            a.rh_to,
            a.tones,
            a.f_lo,
            a.f_hi,
            a.out.display()
        );
    }
    Ok(())
}

#[cfg(test)]
pub mod tests_support {
    use super::*;
    use clap::Parser;

    /// The session of `simulate-sweep --seconds 60` (how data/sweep-40-80.csv was made).
    pub fn bundled_sweep_session() -> Session {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            a: SweepArgs,
        }
        sweep_session(&Cli::parse_from(["ipmc", "--seconds", "60", "--out", "unused.csv"]).a)
    }
}
