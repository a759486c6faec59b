//! Reading a session file: its TOML parsed (errors located by [`super::toml_file`]), then every
//! key checked, so that what cannot be simulated is refused naming the key.

use super::file::{Kind, MAX_SAMPLES, MAX_TONES, Session};
use anyhow::{Result, bail};

impl Session {
    pub fn parse(path: &std::path::Path, text: &str) -> Result<Session> {
        let s: Session = super::toml_file::parse(path, text, "`key = value` lines and [humidity], [noise] … tables")?;
        s.validate().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
        Ok(s)
    }

    /// Rejects sessions that cannot be simulated, naming the key.
    pub fn validate(&self) -> Result<()> {
        let positive = |name: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v > 0.0) {
                bail!("{name} = {v}: expected a positive number");
            }
            Ok(())
        };
        let non_negative = |name: &str, v: f64| -> Result<()> {
            if !(v.is_finite() && v >= 0.0) {
                bail!("{name} = {v}: expected a number ≥ 0");
            }
            Ok(())
        };
        let h = &self.humidity;
        if h.levels_pct.is_empty() {
            bail!("humidity.levels_pct is empty: give at least one level");
        }
        if let Some(v) = h.levels_pct.iter().find(|v| !(v.is_finite() && (0.0..=100.0).contains(*v))) {
            bail!("humidity.levels_pct has {v}: expected levels within 0–100 %");
        }
        non_negative("humidity.settle_s", h.settle_s)?;
        non_negative("humidity.hydration_tau_s", h.hydration_tau_s)?;
        non_negative("humidity.read_error_pct", h.read_error_pct)?;
        non_negative("humidity.level_read_error_pct", h.level_read_error_pct)?;
        if !h.read_bias_pct.is_finite() {
            bail!("humidity.read_bias_pct must be finite");
        }
        positive("humidity.read_gain", h.read_gain)?;
        if let Some(t) = h.hydration_tau_dry_s {
            non_negative("humidity.hydration_tau_dry_s", t)?;
        }
        for (name, v) in [
            ("humidity.chamber_tau_s", h.chamber_tau_s),
            ("humidity.chamber_wander_pct", h.chamber_wander_pct),
            ("humidity.level_error_pct", h.level_error_pct),
            ("humidity.settle_jitter_s", h.settle_jitter_s),
            ("temp_swing_k", self.temp_swing_k),
            ("temp_read_error_k", self.temp_read_error_k),
        ] {
            non_negative(name, v)?;
        }
        if self.temp_c.is_none() && (self.temp_swing_k > 0.0 || self.temp_read_error_k > 0.0) {
            bail!("temp_swing_k and temp_read_error_k need temp_c (the room's temperature)");
        }
        for (k, name) in ["Y", "Cs", "Ca", "d"].iter().enumerate() {
            non_negative(&format!("sample.drift_pct[{k}] ({name})"), self.sample.drift_pct[k])?;
            non_negative(&format!("sample.scatter_pct[{k}] ({name})"), self.sample.scatter_pct[k])?;
            if let Some(drift) = self.sample.drift {
                positive(&format!("sample.drift[{k}] ({name})"), drift[k])?;
            }
        }
        if let Some(t) = self.temp_c
            && !(t.is_finite() && t > -273.15)
        {
            bail!("temp_c = {t}: expected a temperature above absolute zero");
        }
        let n = &self.noise;
        for (name, v) in [
            ("noise.tip_gain_pct", n.tip_gain_pct),
            ("noise.tip_phase_deg", n.tip_phase_deg),
            ("noise.current_gain_pct", n.current_gain_pct),
            ("noise.current_phase_deg", n.current_phase_deg),
            ("noise.current_a", n.current_a),
            ("noise.current_corner_hz", n.current_corner_hz),
            ("noise.tip_m", n.tip_m),
            ("noise.tip_floor", n.tip_floor),
            ("noise.current_floor_of_peak", n.current_floor_of_peak),
            ("noise.mains_hz", n.mains_hz),
            ("noise.mains_rel", n.mains_rel),
        ] {
            non_negative(name, v)?;
        }
        positive("noise.base_amplitude_m", n.base_amplitude_m)?;
        if let Some([lo, hi]) = n.current_floor_band_hz {
            positive("noise.current_floor_band_hz[0]", lo)?;
            if !(hi.is_finite() && hi >= lo) {
                bail!("noise.current_floor_band_hz = [{lo}, {hi}]: expected 0 < low ≤ high");
            }
        }
        let sections = [
            ("frequencies", self.frequencies.is_some()),
            ("time_series", self.time_series.is_some()),
            ("charging", self.charging.is_some()),
        ];
        let wanted = match self.kind {
            Kind::FrequencyResponse => "frequencies",
            Kind::TimeSeries => "time_series",
            Kind::Charging => "charging",
        };
        for (name, present) in sections {
            if name == wanted && !present {
                bail!("kind = {:?} needs a [{name}] table", self.kind);
            }
            if name != wanted && present {
                bail!("[{name}] does not apply to kind = {:?}", self.kind);
            }
        }
        if let Some(f) = &self.frequencies {
            let list = f.frequencies_hz()?;
            if let Some(v) = list.iter().find(|v| !(v.is_finite() && **v > 0.0)) {
                bail!("frequencies: {v} Hz is not a positive frequency");
            }
            non_negative("frequencies.dwell_s", f.dwell_s)?;
            if let Some(f) = f.full_amplitude_to_hz {
                positive("frequencies.full_amplitude_to_hz", f)?;
            }
        }
        if let Some(t) = &self.time_series {
            positive("time_series.fs_hz", t.fs_hz)?;
            positive("time_series.burst_s", t.burst_s)?;
            if let Some(after) = &t.bursts_after_step_s {
                if t.ramp {
                    bail!("time_series.bursts_after_step_s does not apply to a ramp");
                }
                if after.is_empty() || after.iter().any(|v| !(v.is_finite() && *v >= 0.0)) || after.windows(2).any(|w| w[1] <= w[0]) {
                    bail!("time_series.bursts_after_step_s = {after:?}: expected ascending times ≥ 0 s");
                }
                let last = after[after.len() - 1];
                if last + t.burst_s > h.settle_s {
                    bail!(
                        "time_series.bursts_after_step_s: the last burst ends {} s after its step, after the level's \
                         humidity.settle_s = {} s",
                        last + t.burst_s,
                        h.settle_s
                    );
                }
            }
            if t.state_setpoints && (t.ramp || t.bursts_after_step_s.is_some()) {
                bail!("time_series.state_setpoints: setpoints are stated one per burst, which a ramp or bursts after each step are not");
            }
            let samples = t.bursts(h.levels_pct.len()) as f64 * t.fs_hz * t.burst_s;
            if samples > MAX_SAMPLES {
                bail!("time_series: {samples:e} samples (bursts × burst_s × fs_hz): expected at most {MAX_SAMPLES:e}");
            }
            if t.tones > MAX_TONES {
                bail!("time_series.tones = {}: expected at most {MAX_TONES}", t.tones);
            }
            positive("time_series.from_hz", t.from_hz)?;
            positive("time_series.amplitude_m", t.amplitude_m)?;
            if let Some(g) = t.tone_grid_hz {
                positive("time_series.tone_grid_hz", g)?;
            }
            if t.tones == 0 || t.to_hz < t.from_hz {
                bail!("time_series: need tones ≥ 1 and from_hz ≤ to_hz");
            }
            if t.to_hz >= t.fs_hz / 2.0 {
                bail!("time_series.to_hz = {} Hz is not below Nyquist ({} Hz)", t.to_hz, t.fs_hz / 2.0);
            }
        }
        if let Some(c) = &self.charging {
            positive("charging.fs_hz", c.fs_hz)?;
            positive("charging.duration_s", c.duration_s)?;
            if c.fs_hz * c.duration_s > MAX_SAMPLES {
                bail!("charging: {:e} samples (duration_s × fs_hz): expected at most {MAX_SAMPLES:e}", c.fs_hz * c.duration_s);
            }
            if !(c.voltage_v.is_finite() && c.voltage_v != 0.0) {
                bail!("charging.voltage_v = {}: expected a non-zero voltage", c.voltage_v);
            }
            if let Some(r) = c.leakage_ohm {
                positive("charging.leakage_ohm", r)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const STEP: &str = "kind = \"time-series\"\n[humidity]\nlevels_pct = [45, 60]\nsettle_s = 600\n\
        [time_series]\nfs_hz = 500\nburst_s = 1\ntones = 3\nfrom_hz = 10\nto_hz = 100\namplitude_m = 1e-5\n";

    /// Bursts after each step must end before the level's hold does, ascend, and count in the
    /// session's size.
    #[test]
    fn bursts_after_each_step_are_checked() {
        let parse = |after: &str| Session::parse(std::path::Path::new("s.toml"), &format!("{STEP}bursts_after_step_s = {after}\n"));
        let s = parse("[5, 40, 400]").unwrap();
        assert_eq!(s.time_series.unwrap().bursts(2), 4);
        for bad in ["[5, 600]", "[40, 5]", "[]"] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains("bursts_after_step_s"), "{bad}: {e}");
        }
    }

    /// Setpoints are stated one per burst: not beside bursts after each step, nor on a ramp.
    #[test]
    fn setpoints_are_stated_one_per_burst_only() {
        let parse = |extra: &str| Session::parse(std::path::Path::new("s.toml"), &format!("{STEP}state_setpoints = true\n{extra}"));
        assert!(parse("").is_ok());
        for bad in ["bursts_after_step_s = [5, 40]\n", "ramp = true\n"] {
            let e = parse(bad).unwrap_err().to_string();
            assert!(e.contains("state_setpoints"), "{bad}: {e}");
        }
    }
}
