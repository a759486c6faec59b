//! `ipmc strip-check`: the lab's workflow on one strip, end to end, and what it is worth.
//!
//! 1. `ipmc identify` on the strip's frequency response (one session on the bench), from the
//!    lab's nominal calibration (`--calib`): the strip's own calibration.
//! 2. The current's noise measured on the strip's time series (another session of the same
//!    strip: periodic multisine bursts with the true `base_m`), from the differences of its
//!    consecutive periods, into the calibration's `[uncertainty]`.
//! 3. Every burst made a recording of its own by repeating its whole periods (as `ipmc
//!    vs-exact` does) and compensated by the firmware's f32 chain (`ipmc compensate`'s code) with
//!    the strip's own calibration and with the nominal one; beside them the exact band-limited
//!    inverse of the identified model at the same reading, and, where a truth is given
//!    (`--truth`), the chain and the exact inverse with the perfect calibration of the strip.
//!    All scored alike in the design band against `base_m`.
//!
//! Per level it prints those errors, the error the chain states (1σ) and how much of it is the
//! current's noise; then the rms over the levels and the ratios the workflow is judged by.

use anyhow::{Result, anyhow, bail};
use ipmc_core::InverseKind;
use ipmc_recording::looping::{loop_bursts, noise_density};
use ipmc_recording::write_atomically;
use ipmc_tool::chain::error_table;
use ipmc_tool::identify::{base_calibration, identify};
use ipmc_tool::scoring::Scoring;
use ipmc_tool::strip_check::{Level, load_truth, rms, score};
use ipmc_tool::support::input::read_time_series;
use serde_json::json;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// The strip's frequency-response recording (the bench session identify calibrates on).
    fr: PathBuf,
    /// A time series of the same strip from another session: periodic multisine bursts with
    /// the true base motion `base_m`, one burst per humidity level.
    ts: PathBuf,
    /// The lab's nominal calibration: identify's start and the law shapes, and the calibration
    /// the strip's own one is compared with. `default`, `paper`, or a TOML file.
    #[arg(long)]
    calib: Option<String>,
    /// Write the strip's own calibration here (with the current's noise measured on the time
    /// series).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Standard uncertainty of the humidity readings [%RH] (the bench's, one error per level;
    /// also the time series' for its stated error). Default: what identify estimates from the
    /// frequency response.
    #[arg(long)]
    rh_uncertainty: Option<f64>,
    /// The strip's truth: its perfect calibration (a TOML file, e.g. from `ipmc simulate
    /// --strip-calib`), or an independent generator's truths.json (the time series' entry: each
    /// burst's setpoint and the strip's factors there, see ../shared/external/strips/README.md).
    #[arg(long)]
    truth: Option<PathBuf>,
    /// Period of the excitation [s] (each burst holds whole periods of it).
    #[arg(long, default_value_t = 1.0)]
    period_s: f64,
    /// Seconds scored per level after the chain's settling.
    #[arg(long, default_value_t = 10.0)]
    seconds: f64,
    /// Also print the summary as one JSON line at the end.
    #[arg(long)]
    json: bool,
}

pub fn run(a: Args) -> Result<()> {
    let (nominal, nominal_name) = base_calibration(a.calib.as_deref())?;
    println!("== identify {} from {nominal_name}", a.fr.display());
    let id = identify(&a.fr, &nominal, &nominal_name, &[], a.rh_uncertainty)?;
    let mut own = id.calib;
    let ts = read_time_series(&a.ts)?;
    if ts.base_m.is_none() {
        bail!("{}: no `base_m` column: the time series must carry the true base motion to be scored", a.ts.display());
    }
    let per = a.period_s * ts.fs_hz;
    if !(per >= 1.0 && (per - per.round()).abs() < 1e-6) {
        bail!("a period of {} s is not a whole number of samples at {} Hz", a.period_s, ts.fs_hz);
    }
    let noise = noise_density(&ts, per.round() as usize).ok_or_else(|| anyhow!("{}: no burst holds two periods", a.ts.display()))?;
    own.uncertainty.current_noise_a_per_rthz = noise;
    let mut nominal_noisy = nominal;
    nominal_noisy.uncertainty.current_noise_a_per_rthz = noise;
    let rh_sd = a.rh_uncertainty.unwrap_or(id.model.hyper.rh_sd_pct);
    println!(
        "\n== compensate {} ({} bursts): the current's noise {noise:.3e} A/√Hz (from its consecutive periods), reading uncertainty {rh_sd:.2} %RH",
        a.ts.display(),
        ts.bursts().len()
    );
    if let Some(out) = &a.out {
        // The file is the calibration as this workflow used it: with the bench's reading
        // uncertainty, not the board sensor's datasheet default.
        let mut written = own;
        written.humidity.uncertainty_pct = Some(rh_sd);
        let text = format!(
            "{}# [uncertainty] current_noise_a_per_rthz: measured on {} (differences of consecutive periods).\n\
             # [humidity] uncertainty_pct: the bench reading's ({rh_sd:.2} %RH); set your sensor's for use in service.\n{}",
            id.text.split_inclusive('\n').take_while(|l| l.starts_with('#')).collect::<String>(),
            a.ts.display(),
            ipmc_core::calibration_file::to_text(&written)
        );
        write_atomically(out, text.as_bytes())?;
        println!("wrote {}", out.display());
    }
    let truth = a.truth.as_ref().map(|p| load_truth(p, &a.ts, &ts, &nominal_noisy)).transpose()?;
    // The own calibration is used as `ipmc compensate` uses it by default: where the session
    // states its chamber's setpoints one per burst, each burst at its placed humidity. The
    // nominal and perfect ones stay at the reading, as ../shared/external/strips/README.md's
    // references are.
    let chamber = match ipmc_tool::humidity::chamber::place_bursts(&ts, rh_sd) {
        Ok(p) => p,
        Err(why) => {
            println!("the chamber's stated setpoints are not used: {why}; the own calibration is taken at the reading too");
            None
        }
    };
    if let Some(p) = &chamber {
        println!("{}", p.describe(rh_sd));
    }

    let period = per.round() as usize;
    let scored = (a.seconds * ts.fs_hz).round() as usize;
    if !scored.is_multiple_of(period) {
        bail!("{} s scored must be a whole number of {} s periods", a.seconds, a.period_s);
    }
    // The scoring skips the settling and the band filter's start-up; each level is looped to
    // that in whole periods and then the seconds scored.
    let scoring = Scoring::new(&own.band, ts.fs_hz, Some(a.period_s))?;
    let settle = scoring.skip();
    let lead = settle.div_ceil(period) * period;
    let looped = loop_bursts(&ts, a.period_s, (lead + scored) as f64 / ts.fs_hz)?;
    let bar = ipmc_tool::support::progress::bar(ts.bursts().len() as u64, "levels");
    let mut levels = vec![];
    for (k, range) in looped.bursts().into_iter().enumerate() {
        let rec = ipmc_tool::exact::against_chain::burst_of(&looped, range.start..(range.start + lead + scored).min(range.end))?;
        let (own_s, est) = match &chamber {
            Some(p) => {
                let mut placed = rec.clone();
                placed.rh_pct.fill(p.rh_pct[k]);
                let mut at_chamber = own;
                at_chamber.humidity = own.humidity.at_strip();
                score(&at_chamber, &placed, p.sd_pct[k], a.period_s)?
            }
            None => score(&own, &rec, rh_sd, a.period_s)?,
        };
        let (nominal_s, _) = score(&nominal_noisy, &rec, rh_sd, a.period_s)?;
        let perfect = truth.as_ref().map(|t| score(t.at(k), &rec, rh_sd, a.period_s).map(|s| s.0)).transpose()?;
        let tail = &est.rel_err[settle.min(est.rel_err.len())..(settle + scored).min(est.rel_err.len())];
        let stated = tail.iter().map(|&e| e as f64).sum::<f64>() / tail.len().max(1) as f64;
        let errors = error_table(&own, None, rec.fs_hz, chamber.as_ref().map_or(rh_sd, |p| p.sd_pct[k]), InverseKind::Exact)?;
        let design_rh = est.rh_pct.last().copied().unwrap_or(f32::NAN) as f64;
        let stated_calibration = errors.calibration_part(design_rh);
        levels.push(Level {
            rh_read_pct: rec.rh_pct.iter().sum::<f64>() / rec.rh_pct.len() as f64,
            rh_placed_pct: chamber.as_ref().map(|p| p.rh_pct[k]),
            own: own_s,
            nominal: nominal_s,
            perfect,
            stated,
            stated_calibration,
        });
        bar.inc(1);
    }
    bar.finish_and_clear();

    println!(
        "error in {}–{} Hz, per level (each burst repeated by whole periods; {} s scored {}; first {:.2} s skipped), %:",
        own.band.low_hz,
        own.band.high_hz,
        a.seconds,
        scoring.describe(),
        settle as f64 / ts.fs_hz
    );
    println!(
        "  level  RH read %{}   nominal chain   own chain   own exact{}   own stated 1σ (calibration, noise)  covered",
        if chamber.is_some() { "   placed %" } else { "" },
        if truth.is_some() { "   perfect chain   perfect exact" } else { "" }
    );
    for (k, l) in levels.iter().enumerate() {
        let noise_part = (l.stated.powi(2) - l.stated_calibration.powi(2)).max(0.0).sqrt();
        println!(
            "  {:>5}  {:>9.2}{}  {:>14.2}  {:>10.2}  {:>10.2}{}  {:>13.2} ({:>5.2}, {:>5.2})  {:>12}",
            k + 1,
            l.rh_read_pct,
            l.rh_placed_pct.map_or(String::new(), |x| format!("  {x:>9.2}")),
            100.0 * l.nominal.chain,
            100.0 * l.own.chain,
            100.0 * l.own.exact,
            l.perfect.map_or(String::new(), |p| format!("  {:>14.2}  {:>14.2}", 100.0 * p.chain, 100.0 * p.exact)),
            100.0 * l.stated,
            100.0 * l.stated_calibration,
            100.0 * noise_part,
            if l.own.chain <= l.stated { "yes" } else { "no" }
        );
    }
    let r = |f: &dyn Fn(&Level) -> f64| rms(levels.iter().map(f));
    let (nominal_rms, own_rms, own_exact_rms) = (r(&|l| l.nominal.chain), r(&|l| l.own.chain), r(&|l| l.own.exact));
    let perfect_rms = truth.as_ref().map(|_| (r(&|l| l.perfect.map_or(0.0, |p| p.chain)), r(&|l| l.perfect.map_or(0.0, |p| p.exact))));
    let covered = levels.iter().filter(|l| l.own.chain <= l.stated).count();
    println!(
        "rms over the {} levels: nominal {:.2} %, own {:.2} % (its exact inverse {:.2} %){}",
        levels.len(),
        100.0 * nominal_rms,
        100.0 * own_rms,
        100.0 * own_exact_rms,
        perfect_rms.map_or(String::new(), |(c, e)| format!(", perfect {:.2} % (its exact inverse {:.2} %)", 100.0 * c, 100.0 * e))
    );
    println!(
        "own / nominal {:.3}{}; the stated 1σ covers the own chain's error at {covered} of {} levels ({:.0} %; honest: 68 %)",
        own_rms / nominal_rms,
        perfect_rms.map_or(String::new(), |(c, _)| format!(", own / perfect {:.3}", own_rms / c)),
        levels.len(),
        100.0 * covered as f64 / levels.len() as f64
    );
    if a.json {
        let summary = json!({
            "levels": levels,
            "nominal_rms": nominal_rms,
            "own_rms": own_rms,
            "own_exact_rms": own_exact_rms,
            "perfect_rms": perfect_rms.map(|p| p.0),
            "perfect_exact_rms": perfect_rms.map(|p| p.1),
            "covered": covered,
            "rh_uncertainty_pct": rh_sd,
            "current_noise_a_per_rthz": noise,
        });
        println!("{summary}");
    }
    Ok(())
}
