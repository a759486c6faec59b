//! Charging recordings (recording-format.md §3): the current after a constant voltage is
//! applied, from which the capacitance and the effective dielectric constant follow.

use crate::{Error, Format, Metadata, Rule, Table, Warning};
use std::fmt::Write as _;

const COLUMNS: [&str; 2] = ["t_s", "current_a"];

#[derive(Clone, Debug, Default, PartialEq)]
pub struct Charging {
    /// Metadata as read (the writer takes `voltage_v` and `rh_pct` from the fields).
    pub metadata: Metadata,
    /// The applied voltage [V] (`# voltage_v`, required, non-zero).
    pub voltage_v: f64,
    /// Humidity during the recording [%] (`# rh_pct`), if given.
    pub rh_pct: Option<f64>,
    /// Strictly increasing sample times [s].
    pub t_s: Vec<f64>,
    pub current_a: Vec<f64>,
}

impl Format for Charging {
    fn from_table(t: &Table) -> Result<(Self, Vec<Warning>), Error> {
        let voltage_v = t
            .metadata_number("voltage_v", Rule::Finite)?
            .ok_or_else(|| Error::file(&t.source, "missing metadata `# voltage_v=U` (the charging voltage [V])"))?;
        if voltage_v == 0.0 {
            return Err(Error::file(&t.source, "metadata `# voltage_v=0`: expected a non-zero voltage"));
        }
        let rh_pct = t.metadata_number("rh_pct", Rule::Humidity)?;
        let tc = t.require("t_s")?;
        let t_s = t.numbers(tc, Rule::Finite)?;
        let current_a = t.numbers(t.require("current_a")?, Rule::Finite)?;
        if t_s.len() < 2 {
            return Err(Error::line(
                &t.source,
                t.header_line,
                "expected at least two samples after the header (the charge is an integral)",
            ));
        }
        if let Some(i) = (1..t_s.len()).find(|&i| t_s[i] <= t_s[i - 1]) {
            return Err(t.error_at(i, tc, format!("expected a time after {} s, found `{}`", t_s[i - 1], t.field(i, tc))));
        }
        let c = Charging { metadata: t.metadata.clone(), voltage_v, rh_pct, t_s, current_a };
        Ok((c, t.unknown_columns(&COLUMNS)))
    }
}

impl Charging {
    /// The recording as CSV (shortest round-trip numbers).
    pub fn to_csv(&self) -> Result<String, Error> {
        if self.t_s.len() != self.current_a.len() {
            return Err(Error::file("(writer)", format!("{} times for {} currents", self.t_s.len(), self.current_a.len())));
        }
        let mut s = String::with_capacity(self.t_s.len() * 28 + 128);
        let _ = writeln!(s, "# voltage_v={}", self.voltage_v);
        if let Some(rh) = self.rh_pct {
            let _ = writeln!(s, "# rh_pct={rh}");
        }
        self.metadata.write(&mut s, &["voltage_v", "rh_pct"]);
        s.push_str("t_s,current_a\n");
        for (t, i) in self.t_s.iter().zip(&self.current_a) {
            let _ = writeln!(s, "{t},{i:e}");
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn voltage_is_required_and_times_increase() {
        let e = Charging::parse("c.csv", "t_s,current_a\n0,1\n1,0.5\n").unwrap_err();
        assert!(e.message.contains("voltage_v"), "{e}");
        let e = Charging::parse("c.csv", "# voltage_v=0\nt_s,current_a\n0,1\n1,0.5\n").unwrap_err();
        assert!(e.message.contains("non-zero"), "{e}");
        let e = Charging::parse("c.csv", "# voltage_v=0.1\nt_s,current_a\n0,1\n1,0.5\n1,0.2\n").unwrap_err();
        assert_eq!(e.to_string(), "c.csv:5:1: column 1 (`t_s`): expected a time after 1 s, found `1`");
        let e = Charging::parse("c.csv", "# voltage_v=0.1\nt_s,current_a\n0,1\n").unwrap_err();
        assert!(e.message.contains("two samples"), "{e}");
    }

    #[test]
    fn round_trip() {
        let (c, w) = Charging::parse("c.csv", "# voltage_v=0.1\n# rh_pct=55\n# who=me\ncurrent_a,t_s\n1e-3,0\n5e-4,0.001\n").unwrap();
        assert!(w.is_empty());
        assert_eq!((c.voltage_v, c.rh_pct), (0.1, Some(55.0)));
        let (back, _) = Charging::parse("c2.csv", &c.to_csv().unwrap()).unwrap();
        assert_eq!(back, c);
    }
}
