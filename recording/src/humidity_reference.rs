//! Humidity reference recordings (recording-format.md §4): the humidity sensor read at references
//! of known humidity (saturated-salt jars), several readings per reference, to fix its offset
//! and gain.

use crate::{Error, Format, Metadata, Rule, Table, Warning};
use std::fmt::Write as _;

const COLUMNS: [&str; 3] = ["reference_rh_pct", "rh_pct", "temp_c"];

#[derive(Clone, Debug, Default, PartialEq)]
pub struct HumidityReference {
    /// Metadata as read (the writer takes `reference` and `reference_uncertainty_pct` from the
    /// fields).
    pub metadata: Metadata,
    /// The kind of reference (`# reference=`, required), e.g. "saturated salts".
    pub reference: String,
    /// The references' own uncertainty [±%RH, 1σ] (`# reference_uncertainty_pct=`, required).
    pub reference_uncertainty_pct: f64,
    /// Per reading: the reference's humidity [%].
    pub reference_rh_pct: Vec<f64>,
    /// Per reading: what the sensor read [%].
    pub rh_pct: Vec<f64>,
    /// Per reading: the temperature at the reference [°C], when recorded.
    pub temp_c: Option<Vec<f64>>,
}

impl Format for HumidityReference {
    fn from_table(t: &Table) -> Result<(Self, Vec<Warning>), Error> {
        let reference = t
            .metadata
            .get("reference")
            .filter(|r| !r.is_empty())
            .ok_or_else(|| Error::file(&t.source, "missing metadata `# reference=…` (the kind of reference, e.g. saturated salts)"))?
            .to_string();
        let reference_uncertainty_pct = t.metadata_number("reference_uncertainty_pct", Rule::NonNegative)?.ok_or_else(|| {
            Error::file(&t.source, "missing metadata `# reference_uncertainty_pct=U` (the references' own uncertainty, ±%RH)")
        })?;
        let reference_rh_pct = t.numbers(t.require("reference_rh_pct")?, Rule::Humidity)?;
        let rh_pct = t.numbers(t.require("rh_pct")?, Rule::Humidity)?;
        let temp_c = t.find("temp_c").map(|c| t.numbers(c, Rule::Finite)).transpose()?;
        let r = HumidityReference { metadata: t.metadata.clone(), reference, reference_uncertainty_pct, reference_rh_pct, rh_pct, temp_c };
        if r.references().len() < 2 {
            return Err(Error::line(
                &t.source,
                t.header_line,
                "expected readings at two references or more (one fixes an offset, not an offset and a gain)",
            ));
        }
        Ok((r, t.unknown_columns(&COLUMNS)))
    }
}

impl HumidityReference {
    /// The distinct reference humidities, in order of first appearance.
    pub fn references(&self) -> Vec<f64> {
        let mut out: Vec<f64> = Vec::new();
        for &r in &self.reference_rh_pct {
            if !out.contains(&r) {
                out.push(r);
            }
        }
        out
    }

    /// The recording as CSV (shortest round-trip numbers).
    pub fn to_csv(&self) -> Result<String, Error> {
        let n = self.reference_rh_pct.len();
        if self.rh_pct.len() != n || self.temp_c.as_ref().is_some_and(|t| t.len() != n) {
            return Err(Error::file("(writer)", "columns of different lengths"));
        }
        let mut s = String::with_capacity(n * 24 + 256);
        self.metadata.write(&mut s, &["reference", "reference_uncertainty_pct", "format"]);
        let _ = writeln!(s, "# reference={}", self.reference);
        let _ = writeln!(s, "# reference_uncertainty_pct={}", self.reference_uncertainty_pct);
        let _ = writeln!(s, "# format=humidity_reference");
        match &self.temp_c {
            Some(t) => {
                s.push_str("reference_rh_pct,rh_pct,temp_c\n");
                for i in 0..n {
                    let _ = writeln!(s, "{},{},{}", self.reference_rh_pct[i], self.rh_pct[i], t[i]);
                }
            }
            None => {
                s.push_str("reference_rh_pct,rh_pct\n");
                for i in 0..n {
                    let _ = writeln!(s, "{},{}", self.reference_rh_pct[i], self.rh_pct[i]);
                }
            }
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "# reference=saturated salts\n# reference_uncertainty_pct=0.3\n";

    #[test]
    fn metadata_is_required_and_two_references_are_needed() {
        let body = "reference_rh_pct,rh_pct\n32.8,33.0\n75.3,75.9\n";
        let e = HumidityReference::parse("r.csv", body).unwrap_err();
        assert!(e.message.contains("# reference="), "{e}");
        let e = HumidityReference::parse("r.csv", &format!("# reference=salts\n{body}")).unwrap_err();
        assert!(e.message.contains("reference_uncertainty_pct"), "{e}");
        let e = HumidityReference::parse("r.csv", &format!("{HEAD}reference_rh_pct,rh_pct\n32.8,33.0\n32.8,33.1\n")).unwrap_err();
        assert!(e.message.contains("two references"), "{e}");
        let e = HumidityReference::parse("r.csv", &format!("{HEAD}reference_rh_pct,rh_pct\n32.8,33.0\n75.3,175\n")).unwrap_err();
        assert_eq!(e.line, Some(5), "{e}");
    }

    #[test]
    fn round_trip() {
        let text = format!("{HEAD}# strip=case07.csv\nreference_rh_pct,rh_pct,temp_c\n32.8,33.0,24.8\n32.8,33.1,24.9\n75.3,75.9,25.0\n");
        let (r, w) = HumidityReference::parse("r.csv", &text).unwrap();
        assert!(w.is_empty());
        assert_eq!(r.references(), vec![32.8, 75.3]);
        assert_eq!(r.reference_uncertainty_pct, 0.3);
        let (back, _) = HumidityReference::parse("r2.csv", &r.to_csv().unwrap()).unwrap();
        assert_eq!(back.rh_pct, r.rh_pct);
        assert_eq!(back.temp_c, r.temp_c);
        assert_eq!(back.metadata.get("strip"), Some("case07.csv"));
    }
}
