//! Time-series recordings (recording-format.md §2): uniformly sampled bursts of current,
//! humidity and optionally the true base and tip motion, and their writer. A time series with
//! the board's accelerometer (`accel_mps2`, §5) is a check.

use crate::{Error, Format, Metadata, Rule, Table, Warning};
use std::fmt::Write as _;
use std::ops::Range;

const COLUMNS: [&str; 7] = ["t_s", "base_m", "tip_m", "current_a", "rh_pct", "temp_c", "accel_mps2"];

/// A time-series recording.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TimeSeries {
    /// Metadata as read (the writer takes the rate from `fs_hz`, not from here).
    pub metadata: Metadata,
    /// Sample rate within a burst [Hz].
    pub fs_hz: f64,
    pub t_s: Vec<f64>,
    pub current_a: Vec<f64>,
    pub rh_pct: Vec<f64>,
    pub base_m: Option<Vec<f64>>,
    pub tip_m: Option<Vec<f64>>,
    pub temp_c: Option<Vec<f64>>,
    /// The board's accelerometer on the strip's base, resampled onto the ADC's clock [m/s²]:
    /// present, the recording is a check (§5).
    pub accel_mps2: Option<Vec<f64>>,
}

/// How the writer prints numbers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NumberFormat {
    /// Shortest text that reads back as the same f64.
    Exact,
    /// Time to 1 µs, motion and current to 7 significant digits, RH to 1e-4 %, temperature to
    /// 0.01 °C: about half the size, far below any sensor's noise (the bundled recording).
    Compact,
}

impl Format for TimeSeries {
    fn from_table(t: &Table) -> Result<(Self, Vec<Warning>), Error> {
        let t_s = t.numbers(t.require("t_s")?, Rule::Finite)?;
        let current_a = t.numbers(t.require("current_a")?, Rule::Finite)?;
        let rh_pct = t.numbers(t.require("rh_pct")?, Rule::Humidity)?;
        let optional = |name: &str| t.find(name).map(|c| t.numbers(c, Rule::Finite)).transpose();
        let (base_m, tip_m, temp_c) = (optional("base_m")?, optional("tip_m")?, optional("temp_c")?);
        let accel_mps2 = optional("accel_mps2")?;
        if t_s.is_empty() {
            return Err(Error::line(&t.source, t.header_line, "no data rows after the header"));
        }
        let fs_hz = match t.metadata_number("fs_hz", Rule::Positive)? {
            Some(fs) => fs,
            // Without metadata: the rate of the first two samples.
            None if t_s.len() >= 2 && t_s[1] > t_s[0] => 1.0 / (t_s[1] - t_s[0]),
            None => return Err(Error::file(&t.source, "no `# fs_hz=N` metadata and too few samples to infer the rate")),
        };
        let ts = TimeSeries { metadata: t.metadata.clone(), fs_hz, t_s, current_a, rh_pct, base_m, tip_m, temp_c, accel_mps2 };
        ts.check_spacing(t)?;
        Ok((ts, t.unknown_columns(&COLUMNS)))
    }
}

impl TimeSeries {
    /// The samples are at `fs_hz`: most of `t_s`'s steps are 1/fs_hz (the others start bursts).
    /// Where most are not, every sample would be a burst of its own: refused at the first such
    /// step, with the step and the rate.
    fn check_spacing(&self, t: &Table) -> Result<(), Error> {
        let starts: Vec<usize> = self.bursts().iter().skip(1).map(|b| b.start).collect();
        let steps = self.t_s.len().saturating_sub(1);
        match starts.first() {
            Some(&i) if steps >= 2 && 2 * starts.len() > steps => Err(Error::line(
                &t.source,
                t.line_of(i),
                format!(
                    "`t_s` steps by {} s from the row before, where `# fs_hz={}` spaces the samples {} s apart; {} of the \
                     {steps} steps are not 1/fs_hz: the samples are not at the rate `fs_hz` states (correct `# fs_hz` or `t_s`)",
                    self.t_s[i] - self.t_s[i - 1],
                    self.fs_hz,
                    1.0 / self.fs_hz,
                    starts.len()
                ),
            )),
            _ => Ok(()),
        }
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.t_s.len()
    }

    pub fn is_empty(&self) -> bool {
        self.t_s.is_empty()
    }

    /// Whether the recording is a check: the board's accelerometer recorded the drive.
    pub fn is_check(&self) -> bool {
        self.accel_mps2.is_some()
    }

    /// Index ranges of the uniformly sampled bursts: a step in `t_s` more than half a sample
    /// period away from 1/fs starts a new one.
    pub fn bursts(&self) -> Vec<Range<usize>> {
        let mut out = vec![];
        let mut start = 0;
        for i in 1..self.t_s.len() {
            if ((self.t_s[i] - self.t_s[i - 1]) * self.fs_hz - 1.0).abs() > 0.5 {
                out.push(start..i);
                start = i;
            }
        }
        out.push(start..self.t_s.len());
        out
    }

    /// The recording as CSV: `# fs_hz` first, then the other metadata, then the columns it
    /// carries in the order t_s, base_m, tip_m, current_a, rh_pct, temp_c, accel_mps2.
    pub fn to_csv(&self, format: NumberFormat) -> Result<String, Error> {
        let n = self.t_s.len();
        let cols: Vec<(&str, &[f64])> = [
            ("t_s", Some(&self.t_s)),
            ("base_m", self.base_m.as_ref()),
            ("tip_m", self.tip_m.as_ref()),
            ("current_a", Some(&self.current_a)),
            ("rh_pct", Some(&self.rh_pct)),
            ("temp_c", self.temp_c.as_ref()),
            ("accel_mps2", self.accel_mps2.as_ref()),
        ]
        .into_iter()
        .filter_map(|(name, v)| v.map(|v| (name, v.as_slice())))
        .collect();
        if let Some((name, v)) = cols.iter().find(|(_, v)| v.len() != n) {
            return Err(Error::file("(writer)", format!("column `{name}` has {} values for {n} times", v.len())));
        }
        let mut s = String::with_capacity(n * 12 * cols.len() + 256);
        let _ = writeln!(s, "# fs_hz={}", self.fs_hz);
        self.metadata.write(&mut s, &["fs_hz"]);
        s.push_str(&cols.iter().map(|c| c.0).collect::<Vec<_>>().join(","));
        s.push('\n');
        for i in 0..n {
            for (k, (name, v)) in cols.iter().enumerate() {
                if k > 0 {
                    s.push(',');
                }
                let x = v[i];
                let _ = match (format, *name) {
                    (NumberFormat::Exact, "t_s" | "rh_pct" | "temp_c") => write!(s, "{x}"),
                    (NumberFormat::Exact, _) => write!(s, "{x:e}"),
                    (NumberFormat::Compact, "t_s") => write!(s, "{x:.6}"),
                    (NumberFormat::Compact, "rh_pct") => write!(s, "{x:.4}"),
                    (NumberFormat::Compact, "temp_c") => write!(s, "{x:.2}"),
                    (NumberFormat::Compact, _) => write!(s, "{x:.6e}"),
                };
            }
            s.push('\n');
        }
        Ok(s)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_by_name_with_metadata_and_warnings() {
        let (ts, w) = TimeSeries::parse(
            "r.csv",
            "# fs_hz=2000\n# site=lab\nrh_pct,current_a,t_s,base_m,volts\n45,1e-7,0,1e-6,3\n46,2e-7,0.0005,0,3\n",
        )
        .unwrap();
        assert_eq!(ts.fs_hz, 2000.0);
        assert_eq!(ts.t_s, vec![0.0, 0.0005]);
        assert_eq!(ts.base_m, Some(vec![1e-6, 0.0]));
        assert_eq!(ts.tip_m, None);
        assert_eq!(ts.metadata.get("site"), Some("lab"));
        assert_eq!(w.len(), 1);
        let e = TimeSeries::parse("r.csv", "t_s,current_a,rh_pct\n0,1,45\n0.1,x,45\n").unwrap_err();
        assert_eq!(e.to_string(), "r.csv:3:5: column 2 (`current_a`): expected a finite number, found `x`");
        let e = TimeSeries::parse("r.csv", "t_s,current_a\n0,1\n").unwrap_err();
        assert!(e.to_string().starts_with("r.csv:1:") && e.message.contains("`rh_pct`"), "{e}");
    }

    #[test]
    fn a_check_has_the_accelerometer_and_no_base() {
        let text = "# fs_hz=2000\nt_s,current_a,rh_pct,accel_mps2\n0,1e-7,79,0.5\n0.0005,2e-7,79,-1.25\n";
        let (ts, w) = TimeSeries::parse("c.csv", text).unwrap();
        assert!(ts.is_check() && ts.base_m.is_none() && w.is_empty(), "{w:?}");
        assert_eq!(ts.accel_mps2, Some(vec![0.5, -1.25]));
        let (back, _) = TimeSeries::parse("c.csv", &ts.to_csv(NumberFormat::Exact).unwrap()).unwrap();
        assert_eq!(back.accel_mps2, ts.accel_mps2);
        let (plain, _) = TimeSeries::parse("r.csv", "t_s,current_a,rh_pct\n0,1,45\n0.5,1,45\n").unwrap();
        assert!(!plain.is_check());
        let e = TimeSeries::parse("c.csv", "t_s,current_a,rh_pct,accel_mps2\n0,1,45,nan\n").unwrap_err();
        assert!(e.to_string().contains("`accel_mps2`"), "{e}");
    }

    #[test]
    fn rate_from_metadata_or_first_step() {
        let (ts, _) = TimeSeries::parse("r.csv", "t_s,current_a,rh_pct\n0,1,45\n0.25,1,45\n").unwrap();
        assert_eq!(ts.fs_hz, 4.0);
        assert!(TimeSeries::parse("r.csv", "t_s,current_a,rh_pct\n0,1,45\n").is_err());
        let e = TimeSeries::parse("r.csv", "# fs_hz=-5\nt_s,current_a,rh_pct\n0,1,45\n").unwrap_err();
        assert!(e.message.contains("fs_hz=-5"), "{e}");
    }

    /// Samples not at the rate `fs_hz` states: refused at the first step that is not 1/fs_hz,
    /// naming the step and the rate; bursts apart by gaps are not.
    #[test]
    fn samples_not_at_fs_hz_are_refused_by_their_line() {
        let rows = |dt: f64| (0..10).map(|i| format!("{},1e-9,45\n", i as f64 * dt)).collect::<String>();
        let e = TimeSeries::parse("r.csv", &format!("# fs_hz=2000\nt_s,current_a,rh_pct\n{}", rows(0.001))).unwrap_err();
        assert_eq!(e.line, Some(4), "{e}");
        assert!(e.message.contains("`t_s` steps by 0.001 s") && e.message.contains("fs_hz=2000") && e.message.contains("0.0005 s"), "{e}");
        assert!(TimeSeries::parse("r.csv", &format!("# fs_hz=2000\nt_s,current_a,rh_pct\n{}", rows(0.0005))).is_ok());
        let gapped = format!("# fs_hz=2000\nt_s,current_a,rh_pct\n{}5,1e-9,45\n5.0005,1e-9,45\n", rows(0.0005));
        assert_eq!(TimeSeries::parse("r.csv", &gapped).unwrap().0.bursts().len(), 2);
    }

    #[test]
    fn bursts_split_on_time_gaps() {
        let ts = TimeSeries { fs_hz: 2.0, t_s: vec![0.0, 0.5, 1.0, 5.0, 5.5, 0.0], ..Default::default() };
        assert_eq!(ts.bursts(), vec![0..3, 3..5, 5..6]);
    }

    #[test]
    fn exact_round_trip_and_compact_form() {
        let mut ts = TimeSeries {
            fs_hz: 2000.0,
            t_s: vec![0.0, 0.0005],
            current_a: vec![1.126007123e-8, -3.0],
            rh_pct: vec![40.0, 40.00031],
            base_m: Some(vec![-6.847775e-6, 0.1 + 0.2]),
            ..Default::default()
        };
        ts.metadata.set("generator", "test seed=1");
        let text = ts.to_csv(NumberFormat::Exact).unwrap();
        let (back, _) = TimeSeries::parse("x.csv", &text).unwrap();
        assert_eq!(back.t_s, ts.t_s);
        assert_eq!(back.current_a, ts.current_a);
        assert_eq!(back.base_m, ts.base_m);
        let compact = ts.to_csv(NumberFormat::Compact).unwrap();
        assert_eq!(
            compact,
            "# fs_hz=2000\n# generator=test seed=1\nt_s,base_m,current_a,rh_pct\n0.000000,-6.847775e-6,1.126007e-8,40.0000\n0.000500,3.000000e-1,-3.000000e0,40.0003\n"
        );
        ts.rh_pct.pop();
        assert!(ts.to_csv(NumberFormat::Exact).is_err());
    }
}
