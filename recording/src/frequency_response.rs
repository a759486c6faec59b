//! Frequency-response recordings (recording-format.md §1): rows of (humidity, frequency, gain,
//! phase) for the tip and/or current channel, their grouping into humidity levels in time order,
//! and the writer.

use crate::{Error, Format, Metadata, Rule, Table, Warning};

/// Two levels whose mean readings lie within this many %RH may be the same humidity (a revisit,
/// the level a charging recording was taken at): a humidity sensor's absolute scatter. It does
/// not group points into levels ([`FrequencyResponse::runs`] does).
pub const LEVEL_SCATTER_PCT: f64 = 3.0;
/// A time step this many times the median step between consecutive points starts a new level.
pub const LEVEL_TIME_JUMP: f64 = 4.0;
/// A reading this many of the readings' own noise off the run's recent mean starts a new level.
pub const LEVEL_STEP_SIGMAS: f64 = 6.0;
/// Readings of the run's end the next reading is compared with.
pub const LEVEL_RECENT: usize = 5;
/// Least noise a reading is granted [%RH] (readings written to 0.01 %RH, or noise-free).
pub const LEVEL_NOISE_FLOOR_PCT: f64 = 0.01;

const COLUMNS: [&str; 8] = ["time_s", "rh_pct", "temp_c", "freq_hz", "tip_gain", "tip_phase_deg", "current_gain", "current_phase_deg"];

/// Output over base displacement at one frequency: |H| and arg H in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Response {
    pub gain: f64,
    pub phase_deg: f64,
}

/// One row.
#[derive(Clone, Debug, PartialEq)]
pub struct FrPoint {
    /// 1-based line in the file it was read from (0 for points made in memory).
    pub line: usize,
    pub time_s: Option<f64>,
    pub rh_pct: f64,
    pub temp_c: Option<f64>,
    pub freq_hz: f64,
    /// Tip displacement over base displacement [m/m].
    pub tip: Option<Response>,
    /// Short-circuit current over base displacement [A/m].
    pub current: Option<Response>,
}

/// A whole recording: its points in file order (phases as written).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrequencyResponse {
    pub metadata: Metadata,
    pub points: Vec<FrPoint>,
}

/// The points taken at one humidity level during one visit, sorted by frequency with each
/// channel's phase unwrapped along frequency.
#[derive(Clone, Debug, PartialEq)]
pub struct Level {
    /// Mean humidity reading of the points [%].
    pub rh_pct: f64,
    /// Lowest and highest humidity reading of the points [%].
    pub rh_range: (f64, f64),
    /// Time of the level's first point, when the recording has `time_s`.
    pub start_time_s: Option<f64>,
    /// Index of the first earlier level at the same humidity when the session came back to it
    /// (a revisit; comparing the two shows hysteresis or drift), else `None`.
    pub revisit_of: Option<usize>,
    /// The chamber's setpoint for this visit [%RH], where the recording states its setpoints
    /// (`# rh_levels=`) one per level found ([`crate::stated_setpoints`]).
    pub setpoint_pct: Option<f64>,
    pub points: Vec<FrPoint>,
}

impl Format for FrequencyResponse {
    fn from_table(t: &Table) -> Result<(Self, Vec<Warning>), Error> {
        let rh = t.numbers(t.require("rh_pct")?, Rule::Humidity)?;
        let freq = t.numbers(t.require("freq_hz")?, Rule::Positive)?;
        let optional = |name: &str| t.find(name).map(|c| t.numbers(c, Rule::Finite)).transpose();
        let time = optional("time_s")?;
        let temp = optional("temp_c")?;
        let channel = |name: &str| -> Result<Option<Vec<Response>>, Error> {
            let (g, p) = (t.find(&format!("{name}_gain")), t.find(&format!("{name}_phase_deg")));
            match (g, p) {
                (None, None) => Ok(None),
                (Some(_), None) => Err(t.require(&format!("{name}_phase_deg")).unwrap_err()),
                (None, Some(_)) => Err(t.require(&format!("{name}_gain")).unwrap_err()),
                (Some(g), Some(p)) => {
                    let gains = t.numbers(g, Rule::NonNegative)?;
                    let phases = t.numbers(p, Rule::Finite)?;
                    Ok(Some(gains.into_iter().zip(phases).map(|(gain, phase_deg)| Response { gain, phase_deg }).collect()))
                }
            }
        };
        let (tip, current) = (channel("tip")?, channel("current")?);
        if tip.is_none() && current.is_none() {
            return Err(Error::line(
                &t.source,
                t.header_line,
                "neither channel: expected `tip_gain`,`tip_phase_deg` and/or `current_gain`,`current_phase_deg`",
            ));
        }
        if t.is_empty() {
            return Err(Error::line(&t.source, t.header_line, "no data rows after the header"));
        }
        let points = (0..t.len())
            .map(|i| FrPoint {
                line: t.line_of(i),
                time_s: time.as_ref().map(|v| v[i]),
                rh_pct: rh[i],
                temp_c: temp.as_ref().map(|v| v[i]),
                freq_hz: freq[i],
                tip: tip.as_ref().map(|v| v[i]),
                current: current.as_ref().map(|v| v[i]),
            })
            .collect();
        Ok((FrequencyResponse { metadata: t.metadata.clone(), points }, t.unknown_columns(&COLUMNS)))
    }
}

impl FrequencyResponse {
    /// The humidity levels in the order the session visited them: runs of consecutive points
    /// at one setpoint (recording-format.md §1), see [`Self::runs`].
    pub fn levels(&self) -> Vec<Level> {
        let mut levels: Vec<Level> = Vec::new();
        for run in self.runs() {
            let mut points: Vec<FrPoint> = run.iter().map(|&i| self.points[i].clone()).collect();
            let rh_pct = points.iter().map(|p| p.rh_pct).sum::<f64>() / points.len() as f64;
            let rh_range = points.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| (lo.min(p.rh_pct), hi.max(p.rh_pct)));
            let start_time_s = points[0].time_s;
            points.sort_by(|a, b| a.freq_hz.partial_cmp(&b.freq_hz).expect("frequencies are finite"));
            unwrap_channel(&mut points, |p| p.tip.as_mut());
            unwrap_channel(&mut points, |p| p.current.as_mut());
            // The earlier level nearest in reading, if the sensor's scatter allows it to be the
            // same humidity; never the level just left (a revisit comes back from elsewhere).
            let revisit_of = levels[..levels.len().saturating_sub(1)]
                .iter()
                .enumerate()
                .map(|(k, l)| (k, (l.rh_pct - rh_pct).abs()))
                .filter(|&(_, d)| d <= LEVEL_SCATTER_PCT)
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map(|(k, _)| k);
            levels.push(Level { rh_pct, rh_range, start_time_s, revisit_of, setpoint_pct: None, points });
        }
        // Setpoints pair with levels by visiting order, and only when there is one per level: a
        // level split or lost would pair every later one with the wrong setpoint.
        if let Some(order) = crate::stated_setpoints(&self.metadata).filter(|o| o.len() == levels.len()) {
            for (level, s) in levels.iter_mut().zip(order) {
                level.setpoint_pct = Some(s);
            }
        }
        levels
    }

    /// The points' indices grouped into levels, in time order (`time_s` when every point has it,
    /// else file order). A new level starts where the time jumps by more than
    /// [`LEVEL_TIME_JUMP`] times the median step between consecutive points (a level's dwell;
    /// points of one time-series burst share one time, so each burst is a level of its own), or
    /// where the reading leaves the mean of the run's last [`LEVEL_RECENT`] readings by more than
    /// [`LEVEL_STEP_SIGMAS`] of its own noise. The noise is the readings' own: 1.4826·median
    /// |Δ|/√2 of consecutive readings (most pairs are within a level), at least
    /// [`LEVEL_NOISE_FLOOR_PCT`]. A sensor's absolute error says nothing here: setpoints 2 %RH
    /// apart stay apart when the readings are steadier than that.
    pub fn runs(&self) -> Vec<Vec<usize>> {
        let mut order: Vec<usize> = (0..self.points.len()).collect();
        let timed = self.points.iter().all(|p| p.time_s.is_some());
        if timed {
            order.sort_by(|&a, &b| self.points[a].time_s.partial_cmp(&self.points[b].time_s).expect("times are finite"));
        }
        let median = |mut v: Vec<f64>| -> f64 {
            if v.is_empty() {
                return 0.0;
            }
            v.sort_by(f64::total_cmp);
            let n = v.len();
            if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
        };
        let pairs = || order.windows(2).map(|w| (&self.points[w[0]], &self.points[w[1]]));
        let noise = (1.4826 * median(pairs().map(|(a, b)| (b.rh_pct - a.rh_pct).abs()).collect()) / core::f64::consts::SQRT_2)
            .max(LEVEL_NOISE_FLOOR_PCT);
        let dwell = if timed { median(pairs().map(|(a, b)| b.time_s.unwrap_or(0.0) - a.time_s.unwrap_or(0.0)).collect()) } else { 0.0 };
        let mut runs: Vec<Vec<usize>> = vec![];
        for i in order {
            let p = &self.points[i];
            let joins = runs.last().is_some_and(|run: &Vec<usize>| {
                let last = &self.points[*run.last().expect("runs are never empty")];
                let jumped = timed && p.time_s.unwrap_or(0.0) - last.time_s.unwrap_or(0.0) > LEVEL_TIME_JUMP * dwell;
                let recent = &run[run.len().saturating_sub(LEVEL_RECENT)..];
                let m = recent.len() as f64;
                let mean = recent.iter().map(|&k| self.points[k].rh_pct).sum::<f64>() / m;
                let stepped = (p.rh_pct - mean).abs() > LEVEL_STEP_SIGMAS * noise * (1.0 + 1.0 / m).sqrt();
                !jumped && !stepped
            });
            match runs.last_mut() {
                Some(run) if joins => run.push(i),
                _ => runs.push(vec![i]),
            }
        }
        runs
    }

    /// The recording as CSV. A column is written when the points carry it; points that
    /// disagree on which optional columns they carry are an error (the format has no blanks).
    pub fn to_csv(&self) -> Result<String, Error> {
        let first = self.points.first().ok_or_else(|| Error::file("(writer)", "no points to write"))?;
        let shape = |p: &FrPoint| (p.time_s.is_some(), p.temp_c.is_some(), p.tip.is_some(), p.current.is_some());
        let want = shape(first);
        if let Some(p) = self.points.iter().find(|p| shape(p) != want) {
            return Err(Error::file(
                "(writer)",
                format!("point at {} Hz, RH {} % carries other columns than the first", p.freq_hz, p.rh_pct),
            ));
        }
        if !want.2 && !want.3 {
            return Err(Error::file("(writer)", "points carry neither a tip nor a current response"));
        }
        let (time, temp, tip, cur) = want;
        let mut s = String::new();
        self.metadata.write(&mut s, &[]);
        let mut cols = vec![];
        if time {
            cols.push("time_s");
        }
        cols.push("rh_pct");
        if temp {
            cols.push("temp_c");
        }
        cols.push("freq_hz");
        if tip {
            cols.extend(["tip_gain", "tip_phase_deg"]);
        }
        if cur {
            cols.extend(["current_gain", "current_phase_deg"]);
        }
        s.push_str(&cols.join(","));
        s.push('\n');
        // Shortest round-trip forms: reading back gives the same f64 bits.
        for p in &self.points {
            let mut f: Vec<String> = vec![];
            if let Some(t) = p.time_s {
                f.push(format!("{t}"));
            }
            f.push(format!("{}", p.rh_pct));
            if let Some(t) = p.temp_c {
                f.push(format!("{t}"));
            }
            f.push(format!("{}", p.freq_hz));
            for r in [p.tip, p.current].into_iter().flatten() {
                f.push(format!("{:e}", r.gain));
                f.push(format!("{}", r.phase_deg));
            }
            s.push_str(&f.join(","));
            s.push('\n');
        }
        Ok(s)
    }
}

/// Unwraps the phases of one channel of `points` (sorted by frequency) in place.
fn unwrap_channel(points: &mut [FrPoint], channel: fn(&mut FrPoint) -> Option<&mut Response>) {
    let mut phases: Vec<f64> = points.iter_mut().filter_map(|p| channel(p).map(|r| r.phase_deg)).collect();
    unwrap_degrees(&mut phases);
    for (r, ph) in points.iter_mut().filter_map(channel).zip(phases) {
        r.phase_deg = ph;
    }
}

/// Unwraps phases [deg] in place along their order: each differs from the previous by at most
/// 180°. The first is kept as given.
pub fn unwrap_degrees(phases: &mut [f64]) {
    for i in 1..phases.len() {
        phases[i] -= 360.0 * ((phases[i] - phases[i - 1]) / 360.0).round();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEAD: &str = "# sample=ERI-Au-1\n# L_mm=27.68\n";

    #[test]
    fn columns_in_any_order_with_unknown_warned() {
        let text = format!("{HEAD}current_phase_deg,freq_hz,extra,current_gain,rh_pct\n10,20,x,1e-6,45\n");
        let (fr, w) = FrequencyResponse::parse("f.csv", &text).unwrap();
        assert_eq!(fr.metadata.get("L_mm"), Some("27.68"));
        assert_eq!(fr.points[0].current, Some(Response { gain: 1e-6, phase_deg: 10.0 }));
        assert_eq!(fr.points[0].freq_hz, 20.0);
        assert!(fr.points[0].tip.is_none());
        assert_eq!(w.len(), 1);
        assert!(w[0].to_string().contains("`extra`") && w[0].to_string().starts_with("f.csv:3:"), "{}", w[0]);
    }

    #[test]
    fn missing_columns_are_named() {
        let e = FrequencyResponse::parse("f.csv", "freq_hz,tip_gain,tip_phase_deg\n10,1,0\n").unwrap_err();
        assert!(e.to_string().starts_with("f.csv:1:") && e.message.contains("`rh_pct`"), "{e}");
        let e = FrequencyResponse::parse("f.csv", "rh_pct,freq_hz,tip_gain\n50,10,1\n").unwrap_err();
        assert!(e.message.contains("`tip_phase_deg`"), "{e}");
        let e = FrequencyResponse::parse("f.csv", "rh_pct,freq_hz,current_phase_deg\n50,10,1\n").unwrap_err();
        assert!(e.message.contains("`current_gain`"), "{e}");
        let e = FrequencyResponse::parse("f.csv", "rh_pct,freq_hz\n50,10\n").unwrap_err();
        assert!(e.message.contains("neither channel"), "{e}");
    }

    #[test]
    fn bad_rows_name_line_and_column() {
        let ok = "rh_pct,freq_hz,tip_gain,tip_phase_deg\n50,10,1,0\n";
        let e = FrequencyResponse::parse("f.csv", &format!("{ok}50,20,-0.5,3\n")).unwrap_err();
        assert_eq!(e.to_string(), "f.csv:3:7: column 3 (`tip_gain`): expected a finite number ≥ 0, found `-0.5`");
        let e = FrequencyResponse::parse("f.csv", &format!("{ok}50,0,1,3\n")).unwrap_err();
        assert_eq!(e.to_string(), "f.csv:3:4: column 2 (`freq_hz`): expected a finite number > 0, found `0`");
        let e = FrequencyResponse::parse("f.csv", &format!("{ok}50,-3,1,3\n")).unwrap_err();
        assert!(e.message.contains("> 0"), "{e}");
        let e = FrequencyResponse::parse("f.csv", &format!("{ok}50,20,1,NaN\n")).unwrap_err();
        assert_eq!(e.to_string(), "f.csv:3:9: column 4 (`tip_phase_deg`): expected a finite number, found `NaN`");
        let e = FrequencyResponse::parse("f.csv", &format!("{ok}5O,20,1,2\n")).unwrap_err();
        assert_eq!((e.line, e.field.unwrap().index), (Some(3), Some(1)));
        let e = FrequencyResponse::parse("f.csv", "rh_pct,freq_hz,tip_gain,tip_phase_deg\n").unwrap_err();
        assert!(e.message.contains("no data rows"), "{e}");
    }

    #[test]
    fn levels_keep_time_order_and_revisits() {
        // Up 40 → 60, back down to 40: three levels, the last a revisit of the first. Rows are
        // written out of time order; time_s decides.
        let text = "time_s,rh_pct,freq_hz,tip_gain,tip_phase_deg\n\
                    3,59,10,1,0\n0,40.5,20,1,0\n1,39,10,1,0\n2,61,20,1,0\n4,41,10,1,0\n5,42.5,20,1,0\n";
        let (fr, _) = FrequencyResponse::parse("l.csv", text).unwrap();
        let lv = fr.levels();
        assert_eq!(lv.len(), 3);
        assert_eq!(lv.iter().map(|l| l.points.len()).collect::<Vec<_>>(), vec![2, 2, 2]);
        assert_eq!(lv[0].start_time_s, Some(0.0));
        assert!((lv[0].rh_pct - 39.75).abs() < 1e-12);
        assert_eq!(lv[0].rh_range, (39.0, 40.5));
        assert_eq!(lv.iter().map(|l| l.revisit_of).collect::<Vec<_>>(), vec![None, None, Some(0)]);
        // Sorted by frequency within the level.
        assert_eq!(lv[0].points.iter().map(|p| p.freq_hz).collect::<Vec<_>>(), vec![10.0, 20.0]);
        // Without times: a reading stepping far beyond the readings' own noise starts a new level,
        // however small the step against a sensor's absolute error (setpoints 2 %RH apart).
        let rows = [50.0, 50.1, 49.9, 50.05, 52.0, 51.9, 52.1, 52.0, 50.0, 50.1];
        let text: String =
            rows.iter().enumerate().fold("rh_pct,freq_hz,tip_gain,tip_phase_deg\n".into(), |s, (i, r)| s + &format!("{r},{},1,0\n", i + 1));
        let (fr, _) = FrequencyResponse::parse("l.csv", &text).unwrap();
        let lv = fr.levels();
        assert_eq!(lv.iter().map(|l| l.points.len()).collect::<Vec<_>>(), vec![4, 4, 2]);
        assert_eq!(lv.iter().map(|l| l.revisit_of).collect::<Vec<_>>(), vec![None, None, Some(0)]);
        // With times: a jump in time starts a level even at the same reading (a session's
        // settling between two setpoints that read alike).
        let text =
            "time_s,rh_pct,freq_hz,tip_gain,tip_phase_deg\n0,40,10,1,0\n2,40.1,20,1,0\n4,40,30,1,0\n150,40.05,10,1,0\n152,40,20,1,0\n";
        let (fr, _) = FrequencyResponse::parse("l.csv", text).unwrap();
        assert_eq!(fr.levels().iter().map(|l| l.points.len()).collect::<Vec<_>>(), vec![3, 2]);
    }

    #[test]
    fn phases_unwrap_along_frequency_per_level() {
        // A phase falling through -180° written wrapped, rows in descending frequency.
        let text = "rh_pct,freq_hz,current_gain,current_phase_deg\n\
                    50,40,1,150\n50,30,1,-170\n50,20,1,-100\n50,10,1,-10\n70,10,1,170\n70,20,1,-175\n";
        let (fr, _) = FrequencyResponse::parse("p.csv", text).unwrap();
        let lv = fr.levels();
        let ph = |l: &Level| l.points.iter().map(|p| p.current.unwrap().phase_deg).collect::<Vec<_>>();
        assert_eq!(ph(&lv[0]), vec![-10.0, -100.0, -170.0, -210.0]);
        assert_eq!(ph(&lv[1]), vec![170.0, 185.0]);
        // The points as read are untouched.
        assert_eq!(fr.points[0].current.unwrap().phase_deg, 150.0);
        let mut v = vec![0.0, 350.0, 700.0, -20.0];
        unwrap_degrees(&mut v);
        assert_eq!(v, vec![0.0, -10.0, -20.0, -20.0]);
    }

    #[test]
    fn writes_what_it_reads_bit_for_bit() {
        let text = "# sample=S\ntime_s,rh_pct,temp_c,freq_hz,tip_gain,tip_phase_deg,current_gain,current_phase_deg\n\
                    0.5,45.25,22.5,10.1,1.0000000000000002,-3.5,1.234e-7,91.25\n1.5,45.5,22.5,400,3e-300,-179.9,0,0\n";
        let (fr, _) = FrequencyResponse::parse("w.csv", text).unwrap();
        let out = fr.to_csv().unwrap();
        let (back, _) = FrequencyResponse::parse("w2.csv", &out).unwrap();
        let strip = |f: &FrequencyResponse| f.points.iter().map(|p| FrPoint { line: 0, ..p.clone() }).collect::<Vec<_>>();
        assert_eq!(strip(&back), strip(&fr));
        assert_eq!(back.metadata, fr.metadata);
        let mut mixed = fr.clone();
        mixed.points[1].temp_c = None;
        assert!(mixed.to_csv().is_err());
    }
}
