//! `ipmc field-table`: for a field recording (a strip in service, with its true `base_m`) and its
//! truths (`truths.json` of `../shared/external/field/`, per second the strip's humidity), the
//! table of the field README: the compensation's error with the reading, with the fused
//! humidity, and with a perfect hygrometer at the strip; and the strip's own estimate: how often
//! there is one from 70 %RH, and how often its stated 1σ covers the truth
//! (`ipmc_tool::field_table`); then the acceptance criteria over the files.

use anyhow::Result;
use ipmc_tool::field_table::{Row, WET_PCT, one};
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct Args {
    /// Field recordings (t_s, base_m, current_a, rh_pct).
    #[arg(required = true)]
    inputs: Vec<PathBuf>,
    /// Calibration identified on each strip's bench session: one per recording, in order.
    #[arg(long, required = true)]
    calib: Vec<String>,
    /// The truths file; its entry is the recording's file stem.
    #[arg(long)]
    truths: PathBuf,
    /// Also print every second: the truth, its average with the spectrum's weights, the reading
    /// path, the strip's estimate and its 1σ (or the refusal), the fused value with its 1σ, and
    /// the fused 1σ the error bars state (without the strip's calibration part), and the lag the
    /// fusion puts on the reading path (its probability-weighted mean).
    #[arg(long)]
    seconds: bool,
}

pub fn run(a: Args) -> Result<()> {
    if a.calib.len() != a.inputs.len() {
        anyhow::bail!("{} recordings and {} calibrations: give one --calib per recording", a.inputs.len(), a.calib.len());
    }
    println!(
        "| file | strip %RH | reading − strip [%RH rms] | fused − strip [%RH rms] | reading [%] | fused [%] | fused, the strip's lag known [%] | the lag and the sensor's offset known [%] | perfect hygrometer [%] | strip estimate: windows from 70 %RH with one | 1σ coverage |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = vec![];
    let mut notes = vec![];
    for (input, calib) in a.inputs.iter().zip(&a.calib) {
        rows.push(one(&a.truths, a.seconds, input, calib, &mut notes)?);
    }
    for n in notes {
        println!("{n}");
    }
    let mut ok = true;
    for (r, input) in rows.iter().zip(&a.inputs) {
        let bound = (1.05 * r.reading).max(1.5 * r.perfect);
        let pass = r.fused <= bound;
        ok &= pass;
        println!(
            "{}: fused {:.1} % ≤ max(1.05 × reading, 1.5 × perfect) = {bound:.1} %: {}",
            input.display(),
            r.fused,
            if pass { "yes" } else { "NO" }
        );
    }
    let wet: Vec<&Row> = rows.iter().filter(|r| r.wet).collect();
    if !wet.is_empty() {
        let rms = |f: &dyn Fn(&Row) -> f64| (wet.iter().map(|r| f(r).powi(2)).sum::<f64>() / wet.len() as f64).sqrt();
        let (fused, reading, perfect) = (rms(&|r| r.fused), rms(&|r| r.reading), rms(&|r| r.perfect));
        let bound = 1.25 * perfect;
        ok &= fused <= bound;
        println!(
            "from {WET_PCT} %RH ({} files): rms fused {fused:.1} % ≤ 1.25 × perfect {perfect:.1} = {bound:.1} % (reading {reading:.1} %): {}",
            wet.len(),
            if fused <= bound { "yes" } else { "NO" }
        );
        if wet.iter().all(|r| r.lag_known.is_some()) {
            let (lag, both) = (rms(&|r| r.lag_known.unwrap().0), rms(&|r| r.lag_known.unwrap().1));
            println!(
                "from {WET_PCT} %RH, what limits fused: the strip's lag known {lag:.1} %; the lag and the sensor's mean offset known {both:.1} % (a correction no data give)"
            );
        }
    }
    println!("criteria: {}", if ok { "hold" } else { "do NOT hold" });
    Ok(())
}
