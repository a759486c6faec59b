//! What `ipmc identify` prints: the levels as grouped, each level's parameters with their
//! standard errors, the laws through them and their tests (a warning where a law does not hold).

use ipmc_core::ParamName;
use ipmc_fit::estimate::Estimate;
use ipmc_fit::identify::LevelFit;
use ipmc_fit::laws::LawFit;
use ipmc_recording::Level;

/// A law whose χ² has a chance below this of arising if the law held (with the levels' errors
/// honest) is reported as not holding: a 0.1 % test.
pub const LAW_TEST_LEVEL: f64 = 1e-3;

/// The grouping into levels, numbered from 1 as every output numbers them.
pub fn print_levels(levels: &[Level]) {
    println!(
        "levels: {} runs of consecutive points at one setpoint (a new level where the time jumps or the reading steps beyond its own noise)",
        levels.len()
    );
    println!("  level  RH read %  readings %      points  time s          revisits");
    for (k, l) in levels.iter().enumerate() {
        let times: Option<Vec<f64>> = l.points.iter().map(|p| p.time_s).collect();
        let span = times.map_or("—".into(), |t| {
            format!("{:.0}–{:.0}", t.iter().copied().fold(f64::INFINITY, f64::min), t.iter().copied().fold(f64::NEG_INFINITY, f64::max))
        });
        println!(
            "  {:>5}  {:>9.2}  {:>5.2}–{:<7.2}  {:>6}  {:<14}  {}",
            k + 1,
            l.rh_pct,
            l.rh_range.0,
            l.rh_range.1,
            l.points.len(),
            span,
            l.revisit_of.map_or(String::new(), |r| format!("level {}", r + 1))
        );
    }
}

/// A standard error as a percentage, or "not determined".
fn pct_se(value: f64, se: Option<f64>) -> String {
    match se {
        Some(se) if se.is_finite() => format!("±{:>6.2}%", 100.0 * se / value),
        _ => "(SE not determined)".into(),
    }
}

pub fn print_summary(fits: &[(usize, LevelFit)], laws: &[LawFit]) {
    println!("  level  RH %  Y [Pa]               Cs [Pa·s]            Ca [N·s/m²]          d [m²/s]             corr(Cs,Ca)  χ²/dof");
    for (number, f) in fits {
        let cell = |p: ParamName| match f.estimate(p) {
            Some(Estimate { value, se }) => format!("{value:.4e} {}", pct_se(value, se)),
            None => "—".into(),
        };
        let corr = f.correlation(ParamName::Cs, ParamName::Ca).filter(|c| c.is_finite()).map_or("—".into(), |c| format!("{c:+.2}"));
        println!(
            "  {:>5} {:5.1}  {:<20} {:<20} {:<20} {:<20} {:>11}  {:.2}",
            number,
            f.rh_pct,
            cell(ParamName::Y),
            cell(ParamName::Cs),
            cell(ParamName::Ca),
            cell(ParamName::D),
            corr,
            f.fit.reduced_chi2()
        );
    }
    for l in laws {
        let test = match (l.chi2, l.dof, l.p_value) {
            (Some(c), Some(d), Some(p)) => format!("; the law alone: χ² {c:.1} on {} levels ({d} dof), p {}", l.levels, p_text(p)),
            (Some(c), _, _) => format!("; χ² {c:.1} on {} levels", l.levels),
            _ => String::new(),
        };
        let kept = l.departure.map_or(String::new(), |(a, len)| {
            if a > 1e-4 {
                format!("; departures kept: {:.1} % over {len:.1} %RH", 100.0 * a)
            } else {
                "; no departures beyond the errors".into()
            }
        });
        let held_out = l.kept.map_or(String::new(), |t| {
            format!("; what the calibration keeps, each level held out: χ² {:.1} on {} levels, p {}", t.chi2, t.dof, p_text(t.p_value))
        });
        let kind = if l.kind == "log_poly" { "polynomial in RH of ln" } else { "polynomial in RH" };
        println!(
            "law {}: {kind}, degree {}{test}{kept}{held_out}{}",
            l.param,
            l.degree,
            l.note.as_ref().map_or(String::new(), |n| format!(" ({n})"))
        );
    }
    // The test is of what the calibration keeps: a law alone misses a strip with departures by
    // construction (it would warn on 22 of the six shared clean strips' 24 laws).
    for l in laws {
        let (test, what) = match (l.kept, l.chi2, l.dof, l.p_value) {
            (Some(t), ..) => (
                Some((t.chi2, t.dof, t.p_value)),
                "levels held out are not predicted by the rest within their errors: a level read further off than the bench's \
                 reading uncertainty, a law bent by one level, or a strip that departs on a scale the levels cannot resolve",
            ),
            (None, Some(c), Some(d), Some(p)) => (Some((c, d, p)), "the law's shape does not hold, or the levels' errors are too small"),
            _ => (None, ""),
        };
        if let Some((c, d, p)) = test
            && p < LAW_TEST_LEVEL
        {
            eprintln!(
                "warning: law {}: χ² {c:.1} is far above its {d} degrees of freedom (p {} < {LAW_TEST_LEVEL}): {what}",
                l.param,
                p_text(p)
            );
        }
    }
}

/// A probability as text: tiny ones as a bound.
fn p_text(p: f64) -> String {
    if p < 1e-300 {
        "< 1e-300".into()
    } else if p < 1e-3 {
        format!("= {p:.1e}")
    } else {
        format!("= {p:.3}")
    }
}
