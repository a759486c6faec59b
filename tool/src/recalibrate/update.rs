//! What the checks' fits give, as a lab keeps it: the table (each factor with its 1σ, the
//! sensor's offset under both hypotheses, what was decided and what not), and the new
//! calibration: the laws scaled by the factors, the sensor's correction and its uncertainty,
//! and its provenance (the bench calibration, the checks and their dates) in `# provenance:`
//! lines that `ipmc compensate` prints.

use ipmc_core::calibration::checked::{Checked, MAX_CHECKS};
use ipmc_core::{Calibration, LawKind, ParamName};
use std::fmt::Write as _;

use super::response_fit::{CheckData, CheckFit, DRIFTING, Hypothesis};
use super::{Check, Outcome, READING_RESOLUTION_PCT};
use ipmc_core::calibration::lag_offsets::{EQUAL_WEIGHTS, HYDRATION_LAGS_S, LAGS, LagOffsets, NONE_BETWEEN};

/// The key that starts a provenance line.
pub const PROVENANCE: &str = "# provenance:";

/// `t` as YYYY-MM-DD (UTC; the civil calendar from days since 1970, Hinnant's algorithm).
pub fn iso_date(t: std::time::SystemTime) -> String {
    let days = t.duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_secs() / 86_400) as i64;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    format!("{:04}-{m:02}-{d:02}", yoe + era * 400 + i64::from(m <= 2))
}

/// Days since 1970 of a YYYY-MM-DD date (Hinnant's inverse); None if it is not one.
pub fn days_of(date: &str) -> Option<i64> {
    let mut it = date.get(..10)?.split('-').map(|p| p.parse::<i64>().ok());
    let (y, m, d) = (it.next()??, it.next()??, it.next()??);
    let y = if m <= 2 { y - 1 } else { y };
    let era = y.div_euclid(400);
    let yoe = y - era * 400;
    let doy = (153 * (m + if m > 2 { -3 } else { 9 }) + 2) / 5 + d - 1;
    let doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    Some(era * 146_097 + doe - 719_468)
}

/// What `ipmc compensate` says of a calibration file's provenance: which calibration, and how
/// old its last check is on `today` (YYYY-MM-DD). None for a file without provenance lines.
pub fn provenance_said(text: &str, today: &str) -> Option<String> {
    let lines: Vec<&str> = text.lines().filter_map(|l| l.strip_prefix(PROVENANCE)).map(str::trim).collect();
    let first = lines.first()?;
    let last = lines.iter().rev().find_map(|l| l.strip_prefix("last check "))?;
    let age = match (days_of(today), days_of(last)) {
        (Some(t), Some(c)) => format!("{} days ago", t - c),
        _ => "its age unknown".to_string(),
    };
    Some(format!("the calibration: {first}; its last check {last} ({age})"))
}

fn pct(ln: f64) -> f64 {
    100.0 * (ln.exp() - 1.0)
}

/// The table `ipmc recalibrate` prints.
pub fn table(o: &Outcome) -> String {
    let mut s = String::new();
    let chosen = o.chosen();
    let _ = writeln!(s, "checks (the strip's response against the accelerometer, per check; the fit: {:?}):", chosen.hypothesis);
    let _ = writeln!(
        s,
        "  check                               date          reading %RH   strip %RH (fit)   rate ppm   accel gain     delay ms   bins"
    );
    for (c, check) in o.checks.iter().enumerate() {
        let [h, g, d] = chosen.layout.check(c).map(|i| chosen.value(i));
        let name = check.path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
        let _ = writeln!(
            s,
            "  {name:<34}  {:<12}  {:>11.2}   {:>7.2} ± {:<5.2}   {:>8.1}   {:.4} ± {:.4}   {:.3} ± {:.3}   {}",
            check.date,
            check.reading_pct,
            h.0,
            h.1,
            check.measured.rate_ppm,
            g.0,
            g.1,
            d.0,
            d.1,
            check.measured.freq_hz.len()
        );
    }
    let _ = writeln!(
        s,
        "evidence (ln, Laplace): as calibrated {:.1} (χ²/dof {:.2}), drifted {:.1} (χ²/dof {:.2}): {}",
        o.as_calibrated.ln_evidence,
        o.as_calibrated.fit.reduced_chi2(),
        o.drifted.ln_evidence,
        o.drifted.fit.reduced_chi2(),
        match chosen.hypothesis {
            Hypothesis::Drifted => "the strip has drifted beyond its calibration's uncertainty",
            Hypothesis::AsCalibrated => "the strip is as calibrated, within its calibration's uncertainty",
        }
    );
    for f in [&o.as_calibrated, &o.drifted] {
        let (v, sd) = f.value(f.layout.offset());
        let _ = writeln!(
            s,
            "sensor offset (strip − reading), {:?}: {v:+.2} ± {sd:.2} %RH (prior ± {:.2}, the sensor's)",
            f.hypothesis, o.sensor_sd_pct
        );
    }
    let (offset, _) = chosen.value(chosen.layout.offset());
    if let Some(t) = lag_offsets(o, offset) {
        let each: Vec<String> = HYDRATION_LAGS_S
            .iter()
            .enumerate()
            .map(|(k, lag)| format!("{lag:.0} s {:+.2} ± {:.2}", offset + t.offset_pct[k], t.sd_pct[k]))
            .collect();
        let _ = writeln!(s, "sensor offset given the strip's hydration lag, {:?} (%RH): {}", chosen.hypothesis, each.join(", "));
        for (check, parts) in o.checks.iter().zip(&o.parts).filter(|(_, p)| !p.is_empty()) {
            let each: Vec<String> = parts.iter().map(|p| format!("{:.2} ± {:.2}", p.rh_pct, p.sd_pct)).collect();
            let name = check.path.file_name().map_or(String::new(), |n| n.to_string_lossy().into_owned());
            let _ = writeln!(s, "the strip's humidity over {name} in parts of {:.0} s (%RH): {}", super::course::PART_S, each.join(", "));
        }
        match &o.lag_weights {
            Some(_) => {
                let each: Vec<String> = HYDRATION_LAGS_S.iter().zip(t.weight).map(|(lag, w)| format!("{lag:.0} s {w:.2}")).collect();
                let (mean, sd) = over_the_lags(&t);
                let _ = writeln!(
                    s,
                    "the strip's hydration lag, from the checks' course against the reading through each: {}; the offset over them {:+.2} ± {:.2} %RH",
                    each.join(", "),
                    offset + mean,
                    sd
                );
            }
            None => {
                let _ = writeln!(
                    s,
                    "the strip's hydration lag: no check gave a course (it takes two parts of {:.0} s whose humidity the response fixes), every lag alike",
                    super::course::PART_S
                );
            }
        }
    }
    if o.checks.len() == 1 || humidity_span(o) < 5.0 {
        let _ = writeln!(
            s,
            "checks at one humidity cannot tell a sensor offset from a drift of the humidity laws everywhere: both are stated \
             above; a check at another humidity (5 %RH or more away) parts them"
        );
    }
    let _ = writeln!(
        s,
        "  parameter   calibration's 1σ   drift prior   strip / calibration ± 1σ   drift since the bench ± 1σ   decided by the checks"
    );
    for (k, name) in DRIFTING.into_iter().enumerate() {
        let d = &o.drifted;
        let ((v, sd), (_, drift_sd)) = (d.ln_factor(k), d.drift(k));
        let decided = if d.decides(k) { "yes" } else { "no (the prior's)" };
        let _ = writeln!(
            s,
            "  {:<10}  {:>15.1} %  {:>10.1} %   {:>12.4} ± {:.4}   {:>14.4} ± {:.4}     {decided}",
            name.as_str(),
            100.0 * d.calibration_sd[k],
            100.0 * d.drift_sd,
            v.exp(),
            sd * v.exp(),
            v.exp(),
            drift_sd * v.exp()
        );
    }
    let (tau2, tau2_sd) = chosen.value(chosen.layout.tau2());
    let _ = writeln!(s, "electrode's distributed RC line (physics the calibration lacks): {}", electrode_line_text(tau2, tau2_sd));
    s
}

/// τ from τ² [(100 µs)²] with its 1σ, and whether the checks decide it.
pub fn electrode_tau_us(tau2: f64, tau2_sd: f64) -> Option<(f64, f64)> {
    (tau2 > 2.0 * tau2_sd).then(|| (100.0 * tau2.sqrt(), 100.0 * tau2_sd / (2.0 * tau2.sqrt())))
}

fn electrode_line_text(tau2: f64, tau2_sd: f64) -> String {
    match electrode_tau_us(tau2, tau2_sd) {
        Some((tau, sd)) => format!(
            "τ = {tau:.0} ± {sd:.0} µs, decided (a cracked electrode; its in-band effect, a gain fall of 7/90·(ωτ)² and a delay τ/3, is \
             below the calibration's part, and the compensation's model has no term for it)"
        ),
        None => format!(
            "not decided (τ² = {:.3} ± {:.3} (100 µs)²: τ below {:.0} µs at 2σ)",
            tau2,
            tau2_sd,
            100.0 * (tau2.max(0.0) + 2.0 * tau2_sd).sqrt()
        ),
    }
}

fn humidity_span(o: &Outcome) -> f64 {
    let r = o.checks.iter().map(|c| c.reading_pct);
    r.clone().fold(f64::NEG_INFINITY, f64::max) - r.fold(f64::INFINITY, f64::min)
}

/// What the checks left unknown of the strip, for the file's `[checked]` table: the chosen fit's
/// posterior axes given the offset and the checks' humidities, the humidities the checks measured the strip's response at,
/// and what [`updated`] widened the file's 1σ by (the drift the checks leave, as the strip's own
/// hygrometer weighs it).
pub fn checked(o: &Outcome) -> Option<Checked> {
    let f = o.chosen();
    let drift_sd = std::array::from_fn(|k| match f.hypothesis {
        Hypothesis::Drifted if widened(DRIFTING[k]) => f.factor_sd_given_offset(k),
        _ => 0.0,
    });
    Checked::new(&measured_at(o), &f.axes_given_humidities(), drift_sd).ok()
}

/// The humidities the checks measured the strip's response at, in the file's frame: each part's
/// where a check has parts (the strip's humidity moved during it, and the response of each part
/// is measured at its own, [`super::course`]), else the check's. Past the table's room, each
/// check's driest and wettest part, then each check's own.
fn measured_at(o: &Outcome) -> Vec<f64> {
    let f = o.chosen();
    let whole = |c: usize| f.value(f.layout.check(c)[0]).0;
    let per_check = |c: usize, ends: bool| -> Vec<f64> {
        let parts: Vec<f64> = o.parts.get(c).map_or(vec![], |p| p.iter().map(|p| p.rh_pct).collect());
        match (parts.is_empty(), ends) {
            (true, _) => vec![whole(c)],
            (false, false) => parts,
            (false, true) => {
                vec![parts.iter().copied().fold(f64::INFINITY, f64::min), parts.iter().copied().fold(f64::NEG_INFINITY, f64::max)]
            }
        }
    };
    let every: Vec<f64> = (0..o.checks.len()).flat_map(|c| per_check(c, false)).collect();
    if every.len() <= MAX_CHECKS {
        return every;
    }
    let ends: Vec<f64> = (0..o.checks.len()).flat_map(|c| per_check(c, true)).collect();
    if ends.len() <= MAX_CHECKS { ends } else { (0..o.checks.len()).map(whole).collect() }
}

/// Whether [`updated`] widens the file's 1σ of `name` under drift (the parameters `[uncertainty]`
/// speaks of).
fn widened(name: ParamName) -> bool {
    matches!(name, ParamName::Y | ParamName::Cs | ParamName::Ca | ParamName::D | ParamName::KappaE)
}

/// `calib` with the chosen fit's factors on its laws, the sensor's correction and its 1σ given
/// those laws, and under drift the factors' 1σ given that correction added to what the
/// calibration does not know.
pub fn updated(calib: &Calibration, o: &Outcome) -> Calibration {
    let f: &CheckFit = o.chosen();
    let mut c = *calib;
    for (k, name) in DRIFTING.into_iter().enumerate() {
        let (ln, _) = f.ln_factor(k);
        match c.law_mut(name) {
            Some(law) => match law.kind {
                LawKind::LogPoly => law.coeffs[0] += ln,
                LawKind::Poly => law.coeffs.iter_mut().for_each(|x| *x *= ln.exp()),
            },
            None if name == ParamName::Alpha0 => c.alpha0 *= ln.exp(),
            None => c.c_minus *= ln.exp(),
        }
        if f.hypothesis == Hypothesis::Drifted && widened(name) {
            // The laws' uncertainty in the frame of the offset the file holds (the ridge between
            // a drift and a humidity offset at one humidity is the offset's, and stated there).
            let sd = f.factor_sd_given_offset(k);
            let u = &mut c.uncertainty;
            let slot = match name {
                ParamName::Y => Some((&mut u.y, 0)),
                ParamName::Cs => Some((&mut u.cs, 1)),
                ParamName::Ca => Some((&mut u.ca, 2)),
                ParamName::D => Some((&mut u.d, 3)),
                ParamName::KappaE => {
                    u.kappa_e = u.kappa_e.hypot(sd);
                    None
                }
                _ => None,
            };
            if let Some((v, row)) = slot {
                *v = v.hypot(sd);
                if let Some(table) = c.departures.sd.as_mut() {
                    table[row].iter_mut().for_each(|x| *x = x.hypot(sd));
                }
            }
        }
    }
    let (offset, _) = f.value(f.layout.offset());
    let table = lag_offsets(o, offset);
    let (over_lags, sd) = table.map_or((0.0, f.offset_sd_given_factors()), |t| over_the_lags(&t));
    c.humidity.offset_pct += offset + over_lags;
    c.humidity.uncertainty_pct = Some(sd.max(0.01));
    c.humidity.lag_offsets = table.map(|t| LagOffsets { offset_pct: t.offset_pct.map(|x| x - over_lags), ..t });
    if let super::Named::Calibration(k) | super::Named::Recording(k) = o.named {
        c.humidity.sensor = Some(k);
    }
    c
}

/// The offset given each hydration lag of the hygrometer's grid, beyond the checks' `offset`
/// over the lags as one, and its 1σ given the lag: each check's strip humidity less the reading
/// through that lag ([`ipmc_core::calibration::lag_offsets`]); each lag's probability from the
/// checks' course ([`super::course`]; equal without one). None where the calibration's path has
/// its own lag, or where the fit's posterior is singular.
pub fn lag_offsets(o: &Outcome, offset: f64) -> Option<LagOffsets> {
    let f = o.chosen();
    let data: Vec<CheckData> = o.checks.iter().map(Check::data).collect();
    let weight = o.lag_weights.as_ref().and_then(|w| <[f64; LAGS]>::try_from(w.weight.as_slice()).ok()).unwrap_or(EQUAL_WEIGHTS);
    let between = o.lag_weights.as_ref().and_then(|w| <[f64; LAGS - 1]>::try_from(w.between.as_slice()).ok()).unwrap_or(NONE_BETWEEN);
    let mut t = LagOffsets { offset_pct: [0.0; LAGS], sd_pct: [0.0; LAGS], weight, between };
    for k in 0..LAGS {
        let through: Vec<f64> = o.checks.iter().map(|c| c.through_lags_pct.get(k).copied()).collect::<Option<_>>()?;
        let (given, sd) = f.offset_given_lag(&data, &through, READING_RESOLUTION_PCT)?;
        (t.offset_pct[k], t.sd_pct[k]) = (given - offset, sd.max(0.01));
    }
    Some(t)
}

/// The offset over the lags as one, by their weights, beyond the table's reference, and its 1σ
/// with the spread over the lags: what a path read without the lags is corrected by.
pub fn over_the_lags(t: &LagOffsets) -> (f64, f64) {
    let mean: f64 = (0..LAGS).map(|k| t.weight[k] * t.offset_pct[k]).sum();
    let var: f64 = (0..LAGS).map(|k| t.weight[k] * (t.sd_pct[k].powi(2) + (t.offset_pct[k] - mean).powi(2))).sum();
    (mean, var.sqrt())
}

/// The new calibration file's text: provenance lines, the bench calibration's own comments, the
/// tables.
pub fn file_text(bench_path: &str, bench_text: &str, new: &Calibration, o: &Outcome, today: &str) -> String {
    let mut s = String::new();
    let chosen = o.chosen();
    let _ = writeln!(s, "{PROVENANCE} recalibrated {today} by `ipmc recalibrate` from the bench calibration {bench_path}");
    for line in bench_text.lines().filter(|l| l.starts_with(PROVENANCE)) {
        let _ = writeln!(s, "{PROVENANCE} (before){}", &line[PROVENANCE.len()..]);
    }
    for (c, check) in o.checks.iter().enumerate() {
        let (h, sd) = chosen.value(chosen.layout.check(c)[0]);
        let _ = writeln!(
            s,
            "{PROVENANCE} check {} made {}: reading {:.2} %RH, the strip at {h:.2} ± {sd:.2} %RH",
            check.path.display(),
            check.date,
            check.reading_pct
        );
    }
    let last = o.checks.iter().map(|c| c.date.split(' ').next().unwrap_or("").to_string()).max().unwrap_or_default();
    let _ = writeln!(s, "{PROVENANCE} last check {last}");
    for line in o.chosen_summary().lines() {
        let _ = writeln!(s, "# {line}");
    }
    for line in bench_text.lines().take_while(|l| l.starts_with('#')).filter(|l| !l.starts_with(PROVENANCE)) {
        let _ = writeln!(s, "{line}");
    }
    s.push_str(&ipmc_core::calibration_file::to_text(new));
    if let Some(c) = checked(o) {
        s.push('\n');
        s.push_str(&ipmc_core::calibration_file::checked_text(&c));
    }
    s
}

impl Outcome {
    /// One line per change the new calibration makes.
    pub fn chosen_summary(&self) -> String {
        let f = self.chosen();
        let (o, sd) = f.value(f.layout.offset());
        let mut s = format!("[humidity] offset_pct {o:+.3} from the checks ({:?}), uncertainty_pct {sd:.3}\n", f.hypothesis);
        for (k, name) in DRIFTING.into_iter().enumerate() {
            let (v, sd) = f.ln_factor(k);
            if f.prior_sd[k] > 0.0 {
                let _ = writeln!(s, "{} × {:.4} ± {:.4} ({:+.1} %)", name.as_str(), v.exp(), sd * v.exp(), pct(v));
            }
        }
        s
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dates_round_trip_and_the_age_is_said() {
        for days in [0i64, 59, 60, 365, 10_957, 20_794] {
            let t = std::time::UNIX_EPOCH + std::time::Duration::from_secs(days as u64 * 86_400);
            assert_eq!(days_of(&iso_date(t)), Some(days), "{}", iso_date(t));
        }
        assert_eq!(iso_date(std::time::UNIX_EPOCH + std::time::Duration::from_secs(20_794 * 86_400)), "2026-12-07");
        let text = format!("{PROVENANCE} recalibrated 2026-12-07 from b.toml\n{PROVENANCE} last check 2026-11-30\ny = 1\n");
        let said = provenance_said(&text, "2026-12-07").unwrap();
        assert!(said.contains("recalibrated 2026-12-07") && said.contains("(7 days ago)"), "{said}");
        assert_eq!(provenance_said("y = 1\n", "2026-12-07"), None);
    }
}
