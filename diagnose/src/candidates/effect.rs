//! The effects the paper's model leaves out, by name: what the simulator can conceal in a
//! session (`ipmc_sim::effects`) and what the diagnosis names (`diagnose::candidates`), so
//! that a name is spelled once and a misspelt one is an error, not a clean case.

use std::fmt;
use std::str::FromStr;

/// Name of the hypothesis "no extension" among the probabilities, beside the effects' names.
pub const NONE: &str = "none";

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Effect {
    ClampCompliance,
    TipMass,
    AirLoading,
    ViscoelasticRelaxation,
    HystereticDamping,
    ElectrodeResistance,
    AmplifierBandwidth,
    CurrentTiming,
    TipTiming,
    CapacitiveFeedthrough,
    MainsInterference,
    HydrationLag,
    HumiditySensorError,
    Temperature,
}

impl Effect {
    pub const ALL: [Effect; 14] = [
        Effect::ClampCompliance,
        Effect::TipMass,
        Effect::AirLoading,
        Effect::ViscoelasticRelaxation,
        Effect::HystereticDamping,
        Effect::ElectrodeResistance,
        Effect::AmplifierBandwidth,
        Effect::CurrentTiming,
        Effect::TipTiming,
        Effect::CapacitiveFeedthrough,
        Effect::MainsInterference,
        Effect::HydrationLag,
        Effect::HumiditySensorError,
        Effect::Temperature,
    ];

    /// The name reports and recordings use (the diagnosis candidate's).
    pub const fn name(self) -> &'static str {
        match self {
            Effect::ClampCompliance => "clamp_compliance",
            Effect::TipMass => "tip_mass",
            Effect::AirLoading => "air_loading",
            Effect::ViscoelasticRelaxation => "viscoelastic_relaxation",
            Effect::HystereticDamping => "hysteretic_damping",
            Effect::ElectrodeResistance => "electrode_resistance",
            Effect::AmplifierBandwidth => "amplifier_bandwidth",
            Effect::CurrentTiming => "current_timing",
            Effect::TipTiming => "tip_timing",
            Effect::CapacitiveFeedthrough => "capacitive_feedthrough",
            Effect::MainsInterference => "mains_interference",
            Effect::HydrationLag => "hydration_lag",
            Effect::HumiditySensorError => "humidity_sensor_error",
            Effect::Temperature => "temperature",
        }
    }
}

impl fmt::Display for Effect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Effect {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Effect::ALL.into_iter().find(|e| e.name() == s).ok_or_else(|| {
            let names: Vec<&str> = Effect::ALL.iter().map(|e| e.name()).collect();
            format!("unknown effect `{s}`; the effects are {}", names.join(", "))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_a_typo_is_refused() {
        for e in Effect::ALL {
            assert_eq!(e.name().parse::<Effect>(), Ok(e));
        }
        assert!("tip_mas".parse::<Effect>().unwrap_err().contains("tip_mass"));
    }
}
