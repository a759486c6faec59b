//! `--set NAME=VALUE`: replaces one parameter at the requested humidity.

use anyhow::{Result, anyhow, bail};
use ipmc_core::{ParamName, Params, Real};

#[derive(Clone, Debug)]
pub struct Override {
    pub name: ParamName,
    pub value: f64,
}

pub fn parse(s: &str) -> Result<Override> {
    let (name, value) = s.split_once('=').ok_or_else(|| anyhow!("--set expects NAME=VALUE, got {s:?}"))?;
    let name = ParamName::parse(name.trim()).ok_or_else(|| {
        let names: Vec<_> = ParamName::ALL.iter().map(|p| p.as_str()).collect();
        anyhow!("unknown parameter {name:?}; one of {}", names.join(" "))
    })?;
    let value: f64 = value.trim().parse().map_err(|e| anyhow!("--set {}: {value:?} is not a number ({e})", name.as_str()))?;
    if !(value.is_finite() && value > 0.0) {
        bail!("--set {}: {value} must be positive and finite ({})", name.as_str(), name.unit());
    }
    Ok(Override { name, value })
}

pub fn apply<T: Real>(p: &mut Params<T>, overrides: &[Override]) {
    for o in overrides {
        p.set(o.name, T::lit(o.value));
    }
}
