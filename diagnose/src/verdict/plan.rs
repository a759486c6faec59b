//! The plan of follow-ups: every protocol not yet taken, ranked by the information it is
//! expected to give per hour of lab time, each with the time it takes and what it is expected
//! to show.
//!
//! The lab time of each protocol is an estimate stated here, from what it records: the
//! wideband sweep four levels, each settled (20 min) and swept through the primary's points and
//! forty more (about 5 min); the step five levels, each held its dwell; the temperature the
//! primary's session again after the room has settled (2 h); the reference three jars, each
//! equilibrated (1 h) and then read. A protocol that gives more bits in a day of work than
//! another in an afternoon is still asked for after it: the ranking is bits per hour.

use ipmc_recording::Protocol;

/// What the primary recording looked like, for the protocols' parameters and lab time.
pub struct Layout {
    pub rh_range_pct: [f64; 2],
    pub band_hz: [f64; 2],
    /// Mean room temperature [°C], when recorded at every level.
    pub temp_c: Option<f64>,
    /// How long the primary sessions took [h] (from their times, else 15 min a level).
    pub session_h: f64,
    /// The follow-ups already among the recordings: not asked for again.
    pub taken: Vec<Protocol>,
}

/// One protocol of the plan.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Planned {
    #[serde(serialize_with = "protocol_name")]
    pub protocol: Protocol,
    /// Expected information [bits]: the entropy of the partition it resolves.
    pub bits: f64,
    /// Lab time [h] (the estimates of this module).
    pub hours: f64,
    pub bits_per_hour: f64,
    /// What it is expected to show, between the hypotheses it resolves.
    pub shows: String,
}

fn protocol_name<S: serde::Serializer>(p: &Protocol, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(p.as_str())
}

/// Lab time [h] of `protocol` after a primary laid out as `layout`; `dwell_s` is the step's
/// dwell at each level.
pub fn lab_hours(protocol: Protocol, layout: &Layout, dwell_s: f64) -> f64 {
    match protocol {
        Protocol::Wideband => 4.0 * (20.0 + 5.0) / 60.0,
        Protocol::Step => 5.0 * dwell_s / 3600.0,
        Protocol::Temperature => 2.0 + layout.session_h,
        Protocol::Reference => 3.0 * (1.0 + 20.0 / 60.0),
    }
}

/// What `protocol` is expected to show between `resolved` (the hypotheses it resolves, most
/// probable first) and the rest.
pub fn shows(protocol: Protocol, resolved: &[String]) -> String {
    let signature = |name: &str| -> Option<&'static str> {
        Some(match name {
            "amplifier_bandwidth" => "an amplifier's pole: the current rolls off as ω^−1 above 1/τ, its phase towards −90°",
            "electrode_resistance" => "an RC line: the current rolls off as ω^−½ above 1/τ, its phase near −45°",
            "current_timing" => "a delay on the current: its phase falls in proportion to f, its gain flat",
            "tip_timing" => "a delay on the tip: its phase falls in proportion to f, its gain flat",
            "tip_mass" => "a tip mass: the second mode lower against the first than a bare beam's 6.27",
            "clamp_compliance" => "a compliant clamp: both modes lower, the second more",
            "viscoelastic_relaxation" => "a viscoelastic law: the second mode's damping against the first's as the law gives",
            "air_loading" => "air loading: damping growing as √ω at the second mode",
            "hysteretic_damping" => "hysteretic damping: the same loss factor at both modes",
            "capacitive_feedthrough" => "feedthrough: a current growing as ω above the band, 90° ahead",
            "hydration_lag" => "a lag: each level's response right after a step trails the reading, settling over the dwell",
            "humidity_sensor_error" => "a sensor error: the readings in the jars off the salts' humidities",
            "temperature" => "a temperature dependence: the stiffness and capacitance moved by α·ΔT at every level",
            _ => return None,
        })
    };
    let named: Vec<&str> = resolved.iter().filter_map(|n| signature(n)).take(2).collect();
    let against = match protocol {
        Protocol::Wideband => "against none: the model's own roll-off to 2 kHz",
        Protocol::Step => "against none: each level at its reading from the first burst",
        Protocol::Temperature => "against none: the same levels at the other temperature",
        Protocol::Reference => "against none: the readings within the jars' uncertainty",
    };
    if named.is_empty() { against.to_string() } else { format!("{}; {against}", named.join("; ")) }
}

/// The protocols with their bits (those not yet taken), ranked by bits per hour, most first;
/// ties (no information) keep the order given.
pub fn rank(bits: &[(Protocol, f64)], layout: &Layout, dwell_s: f64, shows_of: &dyn Fn(Protocol) -> String) -> Vec<Planned> {
    let mut out: Vec<Planned> = bits
        .iter()
        .filter(|(p, _)| !layout.taken.contains(p))
        .map(|&(protocol, bits)| {
            let hours = lab_hours(protocol, layout, dwell_s);
            Planned { protocol, bits, hours, bits_per_hour: bits / hours, shows: shows_of(protocol) }
        })
        .collect();
    out.sort_by(|a, b| b.bits_per_hour.total_cmp(&a.bits_per_hour));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The cheaper of two protocols giving the same bits ranks first; a protocol already taken
    /// is not planned again; the wideband's line says what separates a line from a pole.
    #[test]
    fn bits_per_hour_rank_the_plan() {
        let layout = Layout { rh_range_pct: [40.0, 80.0], band_hz: [10.0, 150.0], temp_c: Some(20.0), session_h: 3.0, taken: vec![] };
        let bits = [(Protocol::Temperature, 1.0), (Protocol::Wideband, 1.0), (Protocol::Step, 0.0)];
        let plan = rank(&bits, &layout, 600.0, &|_| String::new());
        assert_eq!(plan[0].protocol, Protocol::Wideband);
        assert_eq!(plan[1].protocol, Protocol::Temperature);
        assert_eq!(plan[2].bits_per_hour, 0.0);
        let taken = Layout { taken: vec![Protocol::Wideband], ..layout };
        assert!(rank(&bits, &taken, 600.0, &|_| String::new()).iter().all(|p| p.protocol != Protocol::Wideband));
        let s = shows(Protocol::Wideband, &["electrode_resistance".into(), "amplifier_bandwidth".into()]);
        assert!(s.contains("ω^−½") && s.contains("ω^−1"), "{s}");
    }
}
