//! The follow-up recording a diagnosis asks for when it stops short of a name: one protocol of
//! recording-format.md ("Follow-up recordings"), chosen by the information it is expected to
//! give, with its parameters and a recipe a lab can follow.
//!
//! **Which hypotheses are left.** `undecided` and `unexplained`: those the evidence supports,
//! with their probabilities. `none` (and the others too) also keeps the effects this recording
//! cannot carry at the sizes labs meet (a sensor offset under its reach, a lag under its reach,
//! a temperature dependence: [`crate::humidity::reach`]), each weighed against `none` by its
//! prior and its own evidence here, exp(ΔBIC/2), whether or not it passed the gates naming
//! needs: a gate decides what may be stated, not what is worth measuring.
//!
//! **Which protocol.** Each protocol tells apart the hypotheses it resolves from each other and
//! from the rest, and no more (a wideband sweep separates an amplifier pole from an RC line, but
//! says nothing of a sensor offset). Taken as deciding those, its expected information is the
//! entropy of that partition of the probabilities; the protocol with the most is asked for.

use crate::Effect;
use crate::candidates::effect::NONE;
use crate::candidates::score::Score;
use crate::humidity::reach::HumidityReach;
use crate::verdict::decide::PRIOR_NONE;
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

/// What the primary recording looked like, for the protocols' parameters.
pub struct Layout {
    pub rh_range_pct: [f64; 2],
    pub band_hz: [f64; 2],
    /// Mean room temperature [°C], when recorded at every level.
    pub temp_c: Option<f64>,
    /// The follow-ups already among the recordings: not asked for again.
    pub taken: Vec<Protocol>,
}

/// The hypotheses still open and their weights (summing to one), most probable first.
pub fn open_hypotheses(probabilities: &[Probability], scores: &[Score], reach: &HumidityReach, temperatures: bool) -> Vec<Probability> {
    let mut open: Vec<Probability> = probabilities.to_vec();
    let p_none = probabilities.iter().find(|p| p.name == NONE).map_or(0.0, |p| p.probability);
    let lag_open = reach.shortest_lag_s.is_none_or(|t| t > crate::humidity::reach::LAB_LAG_S);
    let offset_open = reach.smallest_offset_pct > crate::humidity::reach::LAB_OFFSET_PCT;
    let below_reach = [(Effect::HumiditySensorError, offset_open), (Effect::HydrationLag, lag_open), (Effect::Temperature, temperatures)];
    if p_none > 0.0 {
        let ln_prior_effect = ((1.0 - PRIOR_NONE) / Effect::ALL.len() as f64).ln();
        for (effect, left) in below_reach {
            if !left || open.iter().any(|p| p.name == effect.name()) {
                continue;
            }
            // Its best form's evidence here; an effect this recording could not score at all
            // (no times, no temperatures) keeps its prior against none.
            let bic = scores
                .iter()
                .filter(|s| s.name == effect.name() && s.applicable && s.delta_bic.is_finite())
                .map(|s| s.delta_bic)
                .fold(f64::NEG_INFINITY, f64::max);
            let bic = if bic.is_finite() { bic } else { 0.0 };
            let odds = (ln_prior_effect - PRIOR_NONE.ln() + bic / 2.0).exp();
            open.push(Probability { name: effect.name().into(), probability: p_none * odds });
        }
    }
    let total: f64 = open.iter().map(|p| p.probability).sum();
    open.iter_mut().for_each(|p| p.probability /= total);
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

/// The follow-up to ask for, or None when the verdict names an effect or nothing is left open
/// that a protocol resolves.
pub fn request(
    verdict: Verdict,
    probabilities: &[Probability],
    scores: &[Score],
    reach: &HumidityReach,
    layout: &Layout,
) -> Option<FollowupRequest> {
    if matches!(verdict, Verdict::Named(_)) {
        return None;
    }
    let offered = || {
        Protocol::ALL.into_iter().filter(|&p| p != Protocol::Temperature || layout.temp_c.is_some()).filter(|p| !layout.taken.contains(p))
    };
    let mut open = open_hypotheses(probabilities, scores, reach, layout.temp_c.is_some());
    let mut bits: Vec<(Protocol, f64)> = offered().map(|p| (p, expected_information(p, &open))).collect();
    // A report that stops short of a name always asks. When what it leans to is resolved by no
    // protocol (mains pickup; a candidate the gates turned down), the effects below this
    // recording's reach are what a follow-up can still find: weighed among themselves, by
    // their prior and their evidence here, as `none` weighs them.
    let nothing = bits.iter().all(|b| b.1 <= 0.0);
    if nothing && verdict != Verdict::None {
        let only_none = [Probability { name: NONE.into(), probability: 1.0 }];
        open = open_hypotheses(&only_none, scores, reach, layout.temp_c.is_some());
        bits = offered().map(|p| (p, expected_information(p, &open))).collect();
    }
    let &(protocol, best) = bits.iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    // A protocol that resolves nothing still open gives no information.
    if best <= 0.0 {
        return None;
    }
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
        expected_information_bits: best,
        alternatives_bits: bits.clone(),
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
            // Three of the longest lag this recording could not name, and ten minutes at least:
            // the lag's settling must be seen to end.
            let lag = reach.shortest_lag_s.unwrap_or(crate::humidity::reach::LONGEST_LAG_S / 10.0);
            r.dwell_s = Some((3.0 * lag).max(600.0));
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
    /// The recipe a lab follows, with the metadata the file needs.
    pub fn recipe(&self, primary: &str) -> String {
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
            "{what} Mark the file `# followup={}` and `# strip={primary}`, then run `ipmc diagnose {primary} FOLLOWUP.csv --report DIR`. It decides between {} (expected information {:.2} bits).",
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

    /// `none` keeps the effects below this recording's reach, weighed by their own evidence:
    /// a lag that leans ahead asks for the step, an offset that leans ahead for the reference.
    #[test]
    fn none_asks_for_what_it_cannot_carry() {
        let reach = HumidityReach { shortest_lag_s: Some(110.0), both_directions: true, smallest_offset_pct: 2.2, measurement: None };
        let score = |name: &str, delta_bic: f64| Score {
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
        };
        let layout = Layout { rh_range_pct: [38.0, 80.0], band_hz: [10.0, 150.0], temp_c: Some(20.0), taken: vec![] };
        let none = [p("none", 1.0)];
        let ask = |scores: &[Score]| request(Verdict::None, &none, scores, &reach, &layout).unwrap().protocol;
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
        assert!(request(Verdict::None, &none, &[score("hydration_lag", 1.0)], &carried, &no_temp).is_none());
        let r = request(Verdict::None, &none, &[score("hydration_lag", 3.6)], &reach, &layout).unwrap();
        assert!(r.dwell_s.unwrap() >= 600.0 && r.humidities_pct.len() == 5, "{r:?}");
        assert!(r.recipe("case07.csv").contains("# strip=case07.csv"));
        // Unexplained, leaning wholly to what no protocol resolves (mains pickup that failed its
        // gates): it still asks, for what is below this recording's reach.
        let mains = [p("mains_interference", 1.0)];
        let lag_ahead = [score("hydration_lag", 2.0), score("humidity_sensor_error", -3.0), score("temperature", -4.0)];
        assert_eq!(request(Verdict::Unexplained, &mains, &lag_ahead, &reach, &layout).map(|r| r.protocol), Some(Protocol::Step));
        assert!(request(Verdict::None, &mains, &lag_ahead, &reach, &layout).is_none());
    }
}
