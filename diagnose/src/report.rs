//! The diagnosis as report.json (for programs) and report.md (for people).

use crate::candidates::LIBRARY;
use crate::verdict::types::{Diagnosis, Verdict};
use serde_json::json;
use std::fmt::Write as _;

/// One figure of the report (drawn by the caller): its title and the stem of its .svg and .png
/// in the report directory.
pub struct Figure {
    pub title: String,
    pub stem: String,
}

/// The options a diagnosis was run with besides its recordings and `--report` (`--calib FILE`,
/// the instrument's tolerances, …), as typed: a suggested command repeats them.
pub struct Rerun<'a> {
    pub inputs: &'a [String],
    pub options: &'a [String],
}

impl Rerun<'_> {
    /// The diagnosis to run with a follow-up: every input this one used, and `FOLLOWUP.csv`.
    pub fn with_followup(&self) -> String {
        let mut words: Vec<&str> = vec!["ipmc", "diagnose"];
        words.extend(self.inputs.iter().map(String::as_str));
        words.push("FOLLOWUP.csv");
        words.extend(self.options.iter().map(String::as_str));
        words.extend(["--report", "DIR"]);
        words.join(" ")
    }
}

pub fn json(d: &Diagnosis, rerun: &Rerun, calib: &str, figures: &[Figure]) -> serde_json::Value {
    let inputs = rerun.inputs;
    json!({
        "verdict": d.verdict,
        "probabilities": d.probabilities,
        "within_none": d.within_none,
        "set": d.set,
        "set_rule": format!("the smallest set of hypotheses holding {:.0} % of the probability, `none` holding the candidates below their floor and the effects this recording cannot carry (within_none); a name is stated only when it alone holds it and passes every gate (else the verdict is undecided)", 100.0 * crate::verdict::decide::CONFIDENCE),
        "tempering": d.tempering,
        "separating_measurement": separating_measurement(d, rerun),
        "no_protocol_left": no_protocol_left(d),
        "humidity_reach": d.humidity_reach,
        "indistinguishable": d.indistinguishable,
        "instrument": d.instrument,
        "overdispersion": d.overdispersion,
        "family": d.family,
        "form": d.form,
        "explanation": d.explanation,
        "params": d.params,
        "heldout_before": d.heldout_before,
        "heldout_after": d.heldout_after,
        "heldout_unit": "held-out χ² per residual, leave-one-level-out (1 = at the noise)",
        "located": d.located,
        "candidates": d.candidates,
        "levels": d.levels,
        "noise": {
            "tip": d.noise.tip,
            "current": d.noise.current,
        },
        "inputs": inputs,
        "calibration": calib,
        "figures": figures.iter().flat_map(|f| [format!("{}.svg", f.stem), format!("{}.png", f.stem)]).collect::<Vec<_>>(),
    })
}

/// What would separate the set's leaders (when two share it) and the follow-up to record: the
/// protocol with its parameters, what it decides between and the recipe; null when the verdict
/// names an effect.
fn separating_measurement(d: &Diagnosis, rerun: &Rerun) -> serde_json::Value {
    if d.separation.is_none() && d.request.is_none() {
        return serde_json::Value::Null;
    }
    let mut m = d.separation.as_ref().map_or_else(|| json!({}), |s| json!(s));
    if let Some(r) = &d.request {
        let mut protocol = json!(r);
        protocol["recipe"] = json!(r.recipe(&primary_name(rerun.inputs), &rerun.with_followup()));
        protocol["command"] = json!(rerun.with_followup());
        m["protocol"] = protocol;
    }
    m
}

/// A report short of a name that asks for no follow-up: every protocol is taken, or none of
/// those left resolves anything still open.
fn no_protocol_left(d: &Diagnosis) -> bool {
    d.verdict.effect().is_none() && d.request.is_none()
}

/// The file name a follow-up's `# strip=` names: the first recording's.
fn primary_name(inputs: &[String]) -> String {
    inputs
        .first()
        .map_or("RECORDING.csv".into(), |p| std::path::Path::new(p).file_name().map_or(p.clone(), |n| n.to_string_lossy().into_owned()))
}

/// The stages of a diagnosis from follow-ups: the probabilities before and after each, and the
/// fit on each follow-up's levels held out.
pub fn stages_markdown(stages: &[crate::strip_diagnosis::Stage], fits: &[crate::strip_diagnosis::FollowupFit]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "\n## Follow-ups\n");
    let _ = writeln!(
        s,
        "The strip and the effect are shared by every recording; each session keeps its own levels, read errors and noise. Each stage adds one follow-up to the ones before.\n"
    );
    let _ = writeln!(s, "| stage | verdict | probabilities |\n|---|---|---|");
    for st in stages {
        let what = match (&st.added, st.protocol) {
            (Some(f), Some(p)) => format!("+ {f} ({p})"),
            _ => "the primary alone".into(),
        };
        let probs =
            st.probabilities.iter().take(4).map(|p| format!("{} {:.1} %", p.name, 100.0 * p.probability)).collect::<Vec<_>>().join(", ");
        let _ = writeln!(s, "| {what} | {} | {probs} |", st.verdict);
    }
    if !fits.is_empty() {
        let _ = writeln!(
            s,
            "\nThe follow-ups' levels held out (each in turn, fitted on every other level, the primary's included; χ² per residual, 1 = at the noise), before and after the verdict:\n"
        );
        let _ = writeln!(s, "| follow-up | levels | before | after |\n|---|---|---|---|");
        for f in fits {
            let _ = writeln!(s, "| {} ({}) | {} | {:.3} | {:.3} |", f.file, f.protocol, f.levels, f.heldout_before, f.heldout_after);
        }
    }
    s
}

fn fmt_value(v: f64) -> String {
    if !v.is_finite() {
        return "not determined".into();
    }
    if v == 0.0 || (1e-3..1e4).contains(&v.abs()) { format!("{v:.4}") } else { format!("{v:.3e}") }
}

pub fn markdown(d: &Diagnosis, rerun: &Rerun, calib: &str, figures: &[Figure]) -> String {
    let inputs = rerun.inputs;
    let mut s = String::new();
    let _ = writeln!(s, "# Diagnosis\n");
    let _ = writeln!(s, "Recordings: {}  \nCalibration: {calib}\n", inputs.join(", "));
    let verdict = match d.verdict {
        Verdict::None => match d.within_none.iter().find(|p| p.name != "none" && d.set.contains(&p.name)) {
            // `none` holds the confidence with candidates below their floor: they are named in
            // the verdict, so that it does not read as "none" against a larger number beside it.
            Some(_) => format!(
                "**No missing physics large enough to name** (`none` holds {}; {}, each below its floor: what it would change is too small to matter or to tell from the noise).{}",
                percent(d, "none"),
                d.set.iter().filter(|n| *n != "none").map(|n| format!("`{n}` {}", within_percent(d, n))).collect::<Vec<_>>().join(", "),
                none_reach(d)
            ),
            None => format!("**No missing physics above the noise** (`none` holds {}).{}", percent(d, "none"), none_reach(d)),
        },
        Verdict::Unexplained => format!("**Unexplained:** {}.", d.explanation),
        Verdict::Undecided => format!("**Undecided:** {}.", d.explanation),
        Verdict::Named(v) if d.form.is_empty() => {
            format!("**{v}** ({}, probability {}): {}.", d.family, percent(d, v.name()), d.explanation)
        }
        Verdict::Named(v) => format!("**{v}**, {} ({}, probability {}): {}.", d.form, d.family, percent(d, v.name()), d.explanation),
    };
    let _ = writeln!(s, "## Verdict\n\n{verdict}\n");
    let _ = writeln!(
        s,
        "Probabilities of the hypotheses the evidence supports (prior: half on no missing physics, the rest shared by the {} effects, an effect fitted in several forms splitting its share; evidence: ΔBIC on Kass & Raftery's approximation); a name is stated only when it alone holds {:.0} %:\n",
        crate::Effect::ALL.len(),
        100.0 * crate::verdict::decide::CONFIDENCE
    );
    let _ = writeln!(s, "| hypothesis | probability | in the set |\n|---|---|---|");
    for p in &d.probabilities {
        let _ = writeln!(s, "| {} | {} | {} |", p.name, stated(p.probability), if d.set.contains(&p.name) { "yes" } else { "" });
        if p.name == "none" {
            for w in d.within_none.iter().filter(|w| w.probability >= 0.0005) {
                let what = if w.name == "none" {
                    "no effect at all".to_string()
                } else if d.candidates.iter().any(|c| c.name == w.name && c.below_floor) {
                    format!("`{}`, below its floor", w.name)
                } else {
                    format!("`{}`, below this recording's reach", w.name)
                };
                let _ = writeln!(s, "| · within none: {what} | {} | |", stated(w.probability));
            }
        }
    }
    let _ = writeln!(s);
    if d.tempering > 1.0 {
        let _ = writeln!(
            s,
            "The evidence between candidates is divided by {:.1}: the best candidate's residuals stay correlated along frequency (a misfit, not noise), so each level carries fewer independent data than points.\n",
            d.tempering
        );
    }
    if let Some(m) = &d.separation {
        let _ = writeln!(s, "**What would separate {} from {}:** {} ({}): {}.\n", m.between[0], m.between[1], m.record, m.band, m.because);
    }
    if let Some(r) = &d.request {
        let _ = writeln!(
            s,
            "**The follow-up that would decide: `{}`.** {}\n",
            r.protocol,
            r.recipe(&primary_name(inputs), &rerun.with_followup())
        );
        let _ = writeln!(s, "The plan, every protocol not yet taken, by expected information per hour of lab time:\n");
        let _ = writeln!(s, "| protocol | bits | lab time | bits per hour | what it is expected to show |\n|---|---|---|---|---|");
        for p in &r.plan {
            let _ = writeln!(s, "| {} | {:.2} | {:.1} h | {:.2} | {} |", p.protocol, p.bits, p.hours, p.bits_per_hour, p.shows);
        }
        let _ = writeln!(s);
    } else if no_protocol_left(d) {
        let _ = writeln!(s, "**No protocol left can decide:** every follow-up protocol is taken or resolves nothing still open here.\n");
    }
    let r = &d.humidity_reach;
    let _ = writeln!(
        s,
        "**What this recording can carry of the humidity path:** a hydration lag from {} ({}), {}.{}\n",
        r.shortest_lag_s.map_or("none (no lag up to an hour moves a level by the floor)".into(), |t| format!("{t:.0} s")),
        if r.both_directions { "levels revisited in the other direction" } else { "one sweep direction" },
        crate::humidity::reach::offset_phrase(r.smallest_offset_pct),
        r.measurement.as_ref().map_or(String::new(), |m| format!(
            " Lab-sized ones ({:.0} s, {:.1} %RH) would need: {} ({}).",
            crate::humidity::reach::LAB_LAG_S,
            crate::humidity::reach::LAB_OFFSET_PCT,
            m.record,
            m.band
        ))
    );
    if !d.indistinguishable.is_empty() {
        let _ = writeln!(s, "**The candidates in the set:**\n");
        let _ = writeln!(
            s,
            "| candidate | probability | ΔBIC | held-out | measurement that would separate it from the most probable |\n|---|---|---|---|---|"
        );
        for a in &d.indistinguishable {
            let _ =
                writeln!(s, "| {} | {:.1} % | {:.1} | {:.3} | {} |", a.name, 100.0 * a.probability, a.delta_bic, a.heldout, a.separate_by);
        }
        let _ = writeln!(s);
    }
    if let Some(c) = d.verdict.effect().and_then(|e| LIBRARY.iter().find(|c| c.effect == e && c.form == d.form)) {
        let _ = writeln!(s, "{}\n", c.doc);
        let _ = writeln!(s, "| parameter | value | standard error | unit |\n|---|---|---|---|");
        for p in d.params.iter().filter(|p| determined(p)) {
            let _ = writeln!(s, "| {} | {} | {} | {} |", p.name, fmt_value(p.value), fmt_value(p.std_error), p.unit);
        }
        let _ = writeln!(s);
    }
    let after_is = d.heldout_after_is.as_deref().unwrap_or("no effect is named, the same model");
    let _ = writeln!(
        s,
        "Held-out error (each humidity level in turn, scored by a model whose tested part was fitted on the other levels; χ² per residual, 1 = at the noise): **{:.3} before, {:.3} after**. Before: {}. After: {}.\n",
        d.heldout_before, d.heldout_after, d.heldout_before_is, after_is
    );
    let _ = writeln!(s, "## The instrument\n");
    let _ = writeln!(
        s,
        "Each channel's gain and a delay the acquisition shares, fitted with the plain model, their tolerances (`[instrument]`) as priors; every candidate is scored on the recordings with them taken out. Σ(departure/tolerance)² = {:.1} over {} channels.\n",
        d.instrument.prior_chi2,
        d.instrument.channels.len()
    );
    let _ = writeln!(s, "| channel | fitted | standard error | prior | unit |\n|---|---|---|---|---|");
    for c in &d.instrument.channels {
        let _ = writeln!(
            s,
            "| {} | {:+.3} | {} | {:+.2} ± {:.2} | {} |",
            c.name,
            c.value,
            c.std_error.map_or("not determined".into(), |e| format!("{e:.3}")),
            c.prior_mean,
            c.prior_sd,
            c.unit
        );
    }
    let _ = writeln!(s);
    let c = &d.located.calibration;
    let _ = writeln!(s, "## Compare\n");
    let _ = writeln!(
        s,
        "The calibration as given fits with χ²/residual {:.2}; refitting Y, Cs, Ca and d at every level brings it to {:.2}. Mean drift from the calibration: Y {:+.1} %, Cs {:+.1} %, Ca {:+.1} %, d {:+.1} %.\n",
        c.simulation_chi2_per_residual, c.refit_chi2_per_residual, c.drift_pct[0], c.drift_pct[1], c.drift_pct[2], c.drift_pct[3]
    );
    let fmt_noise = |n: &Option<ipmc_fit::noise::ChannelNoise>| match n {
        Some(n) => format!("relative {:.2e} (ln gain and phase [rad]) + floor {:.2e}", n.rel, n.floor),
        None => "not recorded".into(),
    };
    let _ =
        writeln!(s, "Noise from neighbouring-point scatter: tip {}; current {}.\n", fmt_noise(&d.noise.tip), fmt_noise(&d.noise.current));
    let _ = writeln!(
        s,
        "## Locate\n\nWhere the recordings depart from the plain model refitted per level, before any candidate is tried (a departure here is a place to look, not a finding: the verdict above says whether any candidate explains it better than the noise and the instrument do): {}.\n",
        d.located.summary
    );
    let _ = writeln!(s, "| where | residuals | χ²/residual | z |\n|---|---|---|---|");
    for r in d.located.channels.iter().chain(&d.located.frequency).chain(&d.located.levels) {
        let _ = writeln!(s, "| {} | {} | {:.2} | {:.1} |", r.name, r.residuals, r.chi2_per_residual, r.z);
    }
    let r = &d.located.resonance_disagreement;
    let _ = writeln!(s, "| {} | {} levels | {:.2} | {:.1} |", r.name, r.residuals, r.chi2_per_residual, r.z);
    if let Some(t) = &d.located.temperature {
        let _ = writeln!(s, "| {} | {} levels | | {:.1} |", t.name, t.residuals, t.z);
    }
    for h in &d.located.hysteresis {
        let _ = writeln!(
            s,
            "| revisit of {:.1} %RH (levels {} → {}) | | | {:.1} |",
            h.rh_pct,
            h.first_level + 1,
            h.revisit_level + 1,
            h.combined_z
        );
    }
    for t in &d.located.trends {
        let _ = writeln!(s, "| trend of {} {} with ln f (ρ = {:.2}) | | | {:.1} |", t.channel, t.component, t.correlation, t.z);
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "## Candidates\n");
    let _ = writeln!(
        s,
        "Passing needs ΔBIC ≥ {} against no extension and a held-out improvement with paired z ≥ {}. ΔBIC on the data are quasi-likelihood: Δχ² divided by the overdispersion ĉ = {:.2} (the best-fitting model's χ² per degree of freedom, at least 1).\n",
        crate::candidates::score::MIN_DELTA_BIC,
        crate::candidates::score::MIN_HELDOUT_Z,
        d.overdispersion
    );
    let _ = writeln!(s, "| candidate | family | ΔBIC | held-out | z | parameters | note |\n|---|---|---|---|---|---|---|");
    for c in &d.candidates {
        let params: Vec<String> = c
            .params
            .iter()
            .filter(|p| determined(p))
            .map(|p| format!("{} = {} ± {} {}", p.name, fmt_value(p.value), fmt_value(p.std_error), p.unit))
            .collect();
        if c.applicable {
            let _ = writeln!(
                s,
                "| {}{} | {} | {} | {} | {} | {} | {} |",
                crate::candidates::label(&c.name, &c.form),
                if c.passes { " ✔" } else { "" },
                c.family,
                fixed(c.delta_bic, 1),
                fixed(c.heldout, 3),
                fixed(c.heldout_z, 1),
                params.join("; "),
                c.note
            );
        } else {
            let _ =
                writeln!(s, "| {} | {} | – | – | – | – | not testable: {} |", crate::candidates::label(&c.name, &c.form), c.family, c.note);
        }
    }
    let _ = writeln!(s);
    let _ = writeln!(s, "## Figures\n");
    let drawn = match &d.heldout_after_is {
        Some(after) => format!(
            "Held out: the models the numbers above score. Residual map, left (before): {}; right (after): {}. Bode overlays at representative levels: the data (dots), the simulation (the calibration at the level's humidity, grey dashed), the held-out model before (blue) and after (red), and, where it differs from the held-out model before, the base model refitted at the level in sample (light blue dashed).",
            d.heldout_before_is, after
        ),
        None => format!(
            "No effect is named, so only the held-out model before is drawn: {}. The residual map shows its residuals. Bode overlays at representative levels: the data (dots), the simulation (the calibration at the level's humidity, grey dashed), that held-out model (blue), and, where it differs from it, the base model refitted at the level in sample (light blue dashed).",
            d.heldout_before_is
        ),
    };
    let _ = writeln!(
        s,
        "{drawn} Colour scale of the residual map: per frequency, the rms of the ln-gain and phase residuals over σ of both channels (σ inflated at the mains lines where the model was scored so).\n"
    );
    for f in figures {
        let _ = writeln!(s, "![{}]({}.svg)  \n[PNG]({}.png)\n", f.title, f.stem, f.stem);
    }
    s
}

/// The stated probability of a hypothesis, as a percentage.
fn percent(d: &Diagnosis, name: &str) -> String {
    d.probabilities.iter().find(|p| p.name == name).map_or("not determined".into(), |p| stated(p.probability))
}

/// The probability `none` holds of a hypothesis within it, as a percentage.
fn within_percent(d: &Diagnosis, name: &str) -> String {
    d.within_none.iter().find(|p| p.name == name).map_or("not determined".into(), |p| stated(p.probability))
}

/// A probability as a percentage: never "100.0 %", which no finite evidence gives; the
/// probabilities are among the hypotheses the evidence supports, not a certainty.
fn stated(p: f64) -> String {
    if p < 1.0 && 100.0 * p >= 99.95 { "> 99.9 %".into() } else { format!("{:.1} %", 100.0 * p) }
}

/// A parameter the data pin down: one whose standard error is not finite was left where its
/// fit started (a rate of 1e-128 "± not determined"), and printing its value says nothing.
fn determined(p: &crate::candidates::score::Estimate) -> bool {
    p.value.is_finite() && p.std_error.is_finite()
}

/// What `none` means beside the departures located: the largest is what the instrument, the
/// scatter between levels and the noise model leave, which no candidate explains better; and
/// `none` rules out only the effects this recording could carry.
fn none_reach(d: &Diagnosis) -> String {
    let l = &d.located;
    let largest = l.channels.iter().chain(&l.frequency).chain(&l.levels).max_by(|a, b| a.z.total_cmp(&b.z));
    let departure = largest.filter(|r| r.z > 3.0).map_or(String::new(), |r| {
        format!(
            " The plain model still departs from the data ({}: χ²/residual {:.2}, z = {:.1}; held-out χ²/residual {:.2}): the instrument's channels, the scatter of the levels' parameters between levels and the noise model estimated from neighbouring points leave that much, and no candidate explains it better than they do.",
            r.name, r.chi2_per_residual, r.z, d.heldout_before
        )
    });
    let r = &d.humidity_reach;
    format!(
        "{departure} `none` rules out only what this recording could name: a hydration lag {}, {}, and each other effect at the size its candidate would have shown with ΔBIC ≥ {} (the candidates' table gives what each found).",
        r.shortest_lag_s.map_or("of any length (no lag up to an hour moves a level by the floor)".into(), |t| format!("from {t:.0} s")),
        crate::humidity::reach::offset_phrase(r.smallest_offset_pct),
        crate::candidates::score::MIN_DELTA_BIC
    )
}

/// A number with `digits` decimals, or "not determined" where it is not finite.
fn fixed(v: f64, digits: usize) -> String {
    if v.is_finite() { format!("{v:.digits$}") } else { "not determined".into() }
}
