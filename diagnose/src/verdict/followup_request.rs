//! The follow-up recording a diagnosis asks for when it stops short of a name: one protocol of
//! recording-format.md ("Follow-up recordings"), chosen by the information it is expected to
//! give, with its parameters and a recipe a lab can follow.
//!
//! **Which hypotheses are left.** Those the report states, with their probabilities, `none`
//! replaced by what it holds ([`within_none`]): the null, the candidates below their floor and
//! the effects this recording cannot carry at the sizes labs meet (a sensor offset under its
//! reach, a lag under its reach, a temperature dependence: [`crate::humidity::reach`]), each
//! weighed within `none` by its prior and its own evidence here, exp(ΔBIC/2), whether or not it
//! passed the gates naming needs: a gate decides what may be stated, not what is worth
//! measuring. The report lists them within `none`, so the information a request states is that
//! of the probabilities beside it.
//!
//! **Which protocol.** Each protocol tells apart the hypotheses it resolves from each other and
//! from the rest, and no more (a wideband sweep separates an amplifier pole from an RC line, but
//! says nothing of a sensor offset). Taken as deciding those, its expected information is the
//! entropy of that partition of the probabilities. The protocols not yet taken are ranked by
//! that information per hour of lab time ([`crate::verdict::plan`]); the first that gives any is
//! asked for, and when none does the report says that no protocol left can decide.

use crate::Effect;
use crate::candidates::effect::NONE;
use crate::candidates::score::Score;
use crate::humidity::reach::HumidityReach;
use crate::verdict::decide::PRIOR_NONE;
pub use crate::verdict::plan::Layout;
use crate::verdict::plan::Planned;
use crate::verdict::types::{FollowupRequest, Probability, Verdict};
use ipmc_recording::Protocol;

/// The effects a protocol resolves, as this diagnosis fits them.
pub fn resolves(protocol: Protocol) -> &'static [Effect] {
    match protocol {
        // Everything whose signature grows or changes with frequency past the primary's band:
        // the amplifier's pole against the electrodes' line and a delay, the second mode.
        Protocol::Wideband => &[
            Effect::AmplifierBandwidth,
            Effect::ElectrodeResistance,
            Effect::CurrentTiming,
            Effect::TipTiming,
            Effect::TipMass,
            Effect::ClampCompliance,
            Effect::ViscoelasticRelaxation,
            Effect::AirLoading,
            Effect::HystereticDamping,
            Effect::CapacitiveFeedthrough,
        ],
        Protocol::Step => &[Effect::HydrationLag],
        Protocol::Temperature => &[Effect::Temperature],
        Protocol::Reference => &[Effect::HumiditySensorError],
    }
}

/// What `none` holds once the effects this recording cannot carry at the sizes labs meet are
/// weighed within it: `within` (the null first, then the candidates below their floor, summing
/// to `none`'s group probability in `probabilities`) with each effect below the recording's
/// reach (a sensor offset, a lag, a temperature dependence with temperatures) that is not
/// already a hypothesis, weighed against the group by its prior and its own evidence here,
/// exp(ΔBIC/2), whether or not it passed the gates naming needs (a gate decides what may be
/// stated, not what is worth measuring). The group's total is unchanged.
///
/// With `leaning_only` (a confident `none` after a follow-up), an effect below the reach enters
/// only where these recordings lean to it (ΔBIC > 0): the first follow-up explores what the
/// primary cannot carry on the prior alone, but once one has been taken and `none` still holds,
/// another asked on the prior alone would cost every clean strip a second session with nothing
/// in the data pointing at it.
pub fn within_none(
    probabilities: &[Probability],
    within: &[Probability],
    scores: &[Score],
    reach: &HumidityReach,
    temperatures: bool,
    leaning_only: bool,
) -> Vec<Probability> {
    let group = probabilities.iter().find(|p| p.name == NONE).map_or(0.0, |p| p.probability);
    let lag_open = reach.shortest_lag_s.is_none_or(|t| t > crate::humidity::reach::LAB_LAG_S);
    let offset_open = reach.smallest_offset_pct > crate::humidity::reach::LAB_OFFSET_PCT;
    let below_reach = [(Effect::HumiditySensorError, offset_open), (Effect::HydrationLag, lag_open), (Effect::Temperature, temperatures)];
    let ln_prior_effect = ((1.0 - PRIOR_NONE) / Effect::ALL.len() as f64).ln();
    let listed = |name: &str| probabilities.iter().chain(within).any(|p| p.name == name);
    let mut odds: Vec<(String, f64)> = Vec::new();
    for (effect, left) in below_reach {
        if !left || listed(effect.name()) {
            continue;
        }
        // Its best form's evidence here; an effect this recording could not score at all
        // (no times, no temperatures) keeps its prior against none.
        let bic = scores
            .iter()
            .filter(|s| s.name == effect.name() && s.applicable && s.delta_bic.is_finite())
            .map(|s| s.delta_bic)
            .fold(f64::NEG_INFINITY, f64::max);
        if leaning_only && !(bic > 0.0) {
            continue;
        }
        let bic = if bic.is_finite() { bic } else { 0.0 };
        odds.push((effect.name().into(), (ln_prior_effect - PRIOR_NONE.ln() + bic / 2.0).exp()));
    }
    let total = 1.0 + odds.iter().map(|o| o.1).sum::<f64>();
    let mut out: Vec<Probability> =
        within.iter().map(|p| Probability { name: p.name.clone(), probability: p.probability / total }).collect();
    out.extend(odds.into_iter().map(|(name, o)| Probability { name, probability: group * o / total }));
    out
}

/// The hypotheses a follow-up weighs (summing to one), most probable first: every stated one
/// but `none`, and what `none` holds in its place.
pub fn open_hypotheses(probabilities: &[Probability], within_none: &[Probability]) -> Vec<Probability> {
    let mut open: Vec<Probability> = probabilities.iter().filter(|p| p.name != NONE).cloned().chain(within_none.iter().cloned()).collect();
    let total: f64 = open.iter().map(|p| p.probability).sum();
    if total > 0.0 {
        open.iter_mut().for_each(|p| p.probability /= total);
    }
    open.sort_by(|a, b| b.probability.total_cmp(&a.probability));
    open
}

/// Entropy [bits] of the partition `protocol` makes of `open`: each hypothesis it resolves a
/// cell of its own, the rest one cell.
pub fn expected_information(protocol: Protocol, open: &[Probability]) -> f64 {
    let resolved = |name: &str| resolves(protocol).iter().any(|e| e.name() == name);
    let mut cells: Vec<f64> = open.iter().filter(|p| resolved(&p.name)).map(|p| p.probability).collect();
    cells.push(open.iter().filter(|p| !resolved(&p.name)).map(|p| p.probability).sum());
    let bits: f64 = cells.iter().filter(|&&p| p > 0.0).map(|p| -p * p.log2()).sum();
    // A single cell holding all of it is no information, not a rounding error's worth of it.
    if bits < 1e-9 { 0.0 } else { bits }
}

/// The protocols a lab can still take after a primary laid out as `layout`: each once, the
/// temperature protocol only where the room's temperature was recorded.
pub fn offered(layout: &Layout) -> Vec<Protocol> {
    Protocol::ALL
        .into_iter()
        .filter(|&p| p != Protocol::Temperature || layout.temp_c.is_some())
        .filter(|p| !layout.taken.contains(p))
        .collect()
}

/// The step's dwell at each level [s]: three of the longest lag this recording could not name,
/// and ten minutes at least (the lag's settling must be seen to end).
fn step_dwell_s(reach: &HumidityReach) -> f64 {
    let lag = reach.shortest_lag_s.unwrap_or(crate::humidity::reach::LONGEST_LAG_S / 10.0);
    (3.0 * lag).max(600.0)
}

/// The plan ([`crate::verdict::plan`]) over `open` ([`open_hypotheses`]): every protocol not yet
/// taken, ranked by bits per hour.
pub fn plan(open: &[Probability], reach: &HumidityReach, layout: &Layout) -> Vec<Planned> {
    let bits: Vec<(Protocol, f64)> = offered(layout).into_iter().map(|p| (p, expected_information(p, open))).collect();
    let resolved_names = |protocol: Protocol| -> Vec<String> {
        open.iter().filter(|p| resolves(protocol).iter().any(|e| e.name() == p.name)).map(|p| p.name.clone()).collect()
    };
    crate::verdict::plan::rank(&bits, layout, step_dwell_s(reach), &|p| crate::verdict::plan::shows(p, &resolved_names(p)))
}

/// The follow-up to ask for: the first of the plan that gives information, or None when the
/// verdict names an effect or no protocol left can decide anything still open.
pub fn request(verdict: Verdict, open: &[Probability], reach: &HumidityReach, layout: &Layout) -> Option<FollowupRequest> {
    if matches!(verdict, Verdict::Named(_)) {
        return None;
    }
    let plan = plan(open, reach, layout);
    let first = plan.iter().find(|p| p.bits > 0.0)?.clone();
    let protocol = first.protocol;
    // What it decides between, as a reader wants it: the hypotheses it resolves that hold a
    // percent or more (the rest are listed in the probabilities), and none.
    let resolved: Vec<&Probability> = open.iter().filter(|p| resolves(protocol).iter().any(|e| e.name() == p.name)).collect();
    let shown = resolved.iter().filter(|p| p.probability >= 0.01).count().max(1);
    let decides_between: Vec<String> =
        resolved.iter().take(shown).map(|p| p.name.clone()).chain(std::iter::once(NONE.to_string())).collect();
    let [lo, hi] = layout.rh_range_pct;
    let mut r = FollowupRequest {
        protocol,
        decides_between,
        expected_information_bits: first.bits,
        alternatives_bits: plan.iter().map(|p| (p.protocol, p.bits)).collect(),
        plan,
        band_hz: None,
        humidities_pct: vec![],
        dwell_s: None,
        bursts_after_step_s: vec![],
        temperature_c: None,
        readings_per_reference: None,
    };
    let round = |x: f64| (x / 5.0).round() * 5.0;
    match protocol {
        Protocol::Wideband => {
            r.band_hz = Some([layout.band_hz[0], 2000.0]);
            r.humidities_pct = (0..4).map(|k| round(lo + (hi - lo) * k as f64 / 3.0)).collect();
        }
        Protocol::Step => {
            let (a, c) = (round(lo + 5.0), round(hi - 5.0));
            let b = round(0.5 * (a + c));
            r.humidities_pct = vec![a, b, c, b, a];
            r.dwell_s = Some(step_dwell_s(reach));
            r.bursts_after_step_s = vec![5.0, 15.0, 40.0, 90.0, 200.0, 400.0];
        }
        Protocol::Temperature => {
            r.band_hz = Some(layout.band_hz);
            // Ten kelvin from the primary: a coefficient of a few tenths of a percent per
            // kelvin then moves the stiffness by several noise widths.
            r.temperature_c = layout.temp_c.map(|t| if t < 25.0 { t + 10.0 } else { t - 10.0 });
        }
        Protocol::Reference => {
            r.humidities_pct = vec![32.8, 43.2, 75.3];
            r.dwell_s = Some(60.0);
            r.readings_per_reference = Some(20);
        }
    }
    Some(r)
}

impl FollowupRequest {
    /// The recipe a lab follows, with the metadata the file needs; `command` is the diagnosis
    /// to run then (every input this one used, and the follow-up).
    pub fn recipe(&self, primary: &str, command: &str) -> String {
        let levels = self.humidities_pct.iter().map(|h| format!("{h:.0}")).collect::<Vec<_>>().join(", ");
        let what = match self.protocol {
            Protocol::Wideband => {
                let [a, b] = self.band_hz.unwrap_or([10.0, 2000.0]);
                format!(
                    "A frequency response (format §1) of the same strip on the same bench: the primary's frequencies, then about 40 log-spaced points to {b:.0} Hz (from {a:.0} Hz), at {levels} %RH, up only. Above the primary's band raise the drive (e.g. 200 m/s²) so the top octave still carries the current."
                )
            }
            Protocol::Step => format!(
                "A time series (format §2) of the same strip while the chamber steps {} %RH, each level held {:.0} s; a burst of one excitation period starting {} s after each step, with the humidity read throughout.",
                self.humidities_pct.iter().map(|h| format!("{h:.0}")).collect::<Vec<_>>().join(" → "),
                self.dwell_s.unwrap_or(600.0),
                self.bursts_after_step_s.iter().map(|t| format!("{t:.0}")).collect::<Vec<_>>().join(", ")
            ),
            Protocol::Temperature => format!(
                "The primary's session again (its levels, sweep directions and band) with the room held at {} ± 0.5 °C, logged in `temp_c`.",
                self.temperature_c.map_or("another temperature".into(), |t| format!("{t:.0}"))
            ),
            Protocol::Reference => format!(
                "The humidity sensor itself (format §4) in sealed jars over saturated salts: MgCl₂ 32.8, K₂CO₃ 43.2, NaCl 75.3 %RH at 25 °C; {} readings per jar, one every {:.0} s after it has equilibrated. Add `# reference=saturated salts` and `# reference_uncertainty_pct=` (the jars' own uncertainty, e.g. 0.3).",
                self.readings_per_reference.unwrap_or(20),
                self.dwell_s.unwrap_or(60.0)
            ),
        };
        format!(
            "{what} Mark the file `# followup={}` and `# strip={primary}`, then run `{command}`. It decides between {} (expected information {:.2} bits).",
            self.protocol,
            self.decides_between.join(", "),
            self.expected_information_bits
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p(name: &str, probability: f64) -> Probability {
        Probability { name: name.into(), probability }
    }

    /// A tie between an amplifier pole and an RC line asks for the wideband sweep; a tie between
    /// an offset and none for the reference; the partition's entropy counts only what the
    /// protocol resolves.
    #[test]
    fn the_protocol_that_resolves_the_tie_wins() {
        let pole = [p("amplifier_bandwidth", 0.5), p("electrode_resistance", 0.5)];
        assert!((expected_information(Protocol::Wideband, &pole) - 1.0).abs() < 1e-12);
        assert_eq!(expected_information(Protocol::Reference, &pole), 0.0);
        let offset = [p("humidity_sensor_error", 0.85), p("none", 0.15)];
        assert!(expected_information(Protocol::Reference, &offset) > 0.6);
        assert_eq!(expected_information(Protocol::Step, &offset), 0.0);
    }

    fn score(name: &str, delta_bic: f64) -> Score {
        Score {
            name: name.into(),
            form: String::new(),
            family: String::new(),
            applicable: true,
            params: vec![],
            delta_chi2: 0.0,
            delta_chi2_per_level: vec![],
            extra_params: 1,
            delta_bic,
            space: crate::candidates::score::Space::LevelParameters,
            heldout: 1.0,
            heldout_per_level: vec![],
            heldout_null: 1.0,
            heldout_null_per_level: vec![],
            heldout_z: 0.0,
            heldout_between_lines: false,
            passes: false,
            note: String::new(),
            other_gates: false,
            below_floor: false,
        }
    }

    /// `none` holds the effects below this recording's reach, weighed by their own evidence:
    /// a lag that leans ahead asks for the step, an offset that leans ahead for the reference;
    /// what `none` holds sums to its probability, and the request's bits are those of the
    /// hypotheses the report states.
    #[test]
    fn none_asks_for_what_it_cannot_carry() {
        let reach = HumidityReach { shortest_lag_s: Some(110.0), both_directions: true, smallest_offset_pct: 2.2, measurement: None };
        let layout = Layout { rh_range_pct: [38.0, 80.0], band_hz: [10.0, 150.0], temp_c: Some(20.0), session_h: 3.0, taken: vec![] };
        let none = [p("none", 1.0)];
        let open_of = |probabilities: &[Probability], within: &[Probability], scores: &[Score], reach: &HumidityReach, temps: bool| {
            let w = within_none(probabilities, within, scores, reach, temps, false);
            let group: f64 = probabilities.iter().filter(|p| p.name == NONE).map(|p| p.probability).sum();
            assert!((w.iter().map(|p| p.probability).sum::<f64>() - group).abs() < 1e-12, "{w:?}");
            open_hypotheses(probabilities, &w)
        };
        let ask = |scores: &[Score]| {
            let open = open_of(&none, &none, scores, &reach, true);
            let r = request(Verdict::None, &open, &reach, &layout).unwrap();
            assert!((r.expected_information_bits - expected_information(r.protocol, &open)).abs() < 1e-12);
            r.protocol
        };
        assert_eq!(ask(&[score("hydration_lag", 3.6), score("humidity_sensor_error", -3.6), score("temperature", -4.0)]), Protocol::Step);
        assert_eq!(
            ask(&[score("hydration_lag", -3.0), score("humidity_sensor_error", 5.5), score("temperature", -4.0)]),
            Protocol::Reference
        );
        assert_eq!(
            ask(&[score("hydration_lag", -3.0), score("humidity_sensor_error", -3.0), score("temperature", 6.0)]),
            Protocol::Temperature
        );
        // A recording that carries lab-sized lags and offsets and has no temperatures asks nothing.
        let carried = HumidityReach { shortest_lag_s: Some(30.0), both_directions: true, smallest_offset_pct: 1.2, measurement: None };
        let no_temp = Layout { temp_c: None, taken: vec![], ..layout };
        let open = open_of(&none, &none, &[score("hydration_lag", 1.0)], &carried, false);
        assert!(request(Verdict::None, &open, &carried, &no_temp).is_none());
        let open = open_of(&none, &none, &[score("hydration_lag", 3.6)], &reach, true);
        let r = request(Verdict::None, &open, &reach, &layout).unwrap();
        assert!(r.dwell_s.unwrap() >= 600.0 && r.humidities_pct.len() == 5, "{r:?}");
        let recipe = r.recipe("case07.csv", "ipmc diagnose case07.csv FOLLOWUP.csv --calib nominal.toml --report DIR");
        assert!(recipe.contains("# strip=case07.csv") && recipe.contains("--calib nominal.toml"), "{recipe}");
        // `none` holding mains pickup below its floor still asks, for what is below this
        // recording's reach; a protocol already taken is not asked for again.
        let grouped = [p("none", 1.0)];
        let within = [p("none", 0.0), p("mains_interference", 1.0)];
        let lag_ahead = [score("hydration_lag", 2.0), score("humidity_sensor_error", -3.0), score("temperature", -4.0)];
        let open = open_of(&grouped, &within, &lag_ahead, &reach, true);
        assert_eq!(request(Verdict::Unexplained, &open, &reach, &layout).map(|r| r.protocol), Some(Protocol::Step));
        let stepped = Layout { taken: vec![Protocol::Step], ..Layout { temp_c: Some(20.0), ..no_temp } };
        assert_ne!(request(Verdict::Unexplained, &open, &reach, &stepped).map(|r| r.protocol), Some(Protocol::Step));
        // After a follow-up, a confident `none` asks only for what the recordings lean to: a
        // temperature dependence they do not favour is not asked for on its prior alone.
        let prior_only = [score("hydration_lag", -3.0), score("humidity_sensor_error", -3.0), score("temperature", -1.0)];
        let w = within_none(&none, &none, &prior_only, &reach, true, true);
        assert_eq!(w.len(), 1, "{w:?}");
        assert!(request(Verdict::None, &open_hypotheses(&none, &w), &reach, &stepped).is_none());
        let leaning = [score("hydration_lag", -3.0), score("humidity_sensor_error", -3.0), score("temperature", 4.0)];
        let w = within_none(&none, &none, &leaning, &reach, true, true);
        let r = request(Verdict::None, &open_hypotheses(&none, &w), &reach, &stepped).unwrap();
        assert_eq!(r.protocol, Protocol::Temperature);
    }
}
