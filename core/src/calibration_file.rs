//! Calibration files: the one reader of the TOML form of [`Calibration`], used by the firmware's
//! build script (`IPMC_CALIB`) and the tool (`--calib`), so both accept and refuse the same files
//! with the same messages.

use std::fmt;

use crate::calibration::checked::Checked;
use crate::calibration::laws::{Calibration, ValidationError};
use crate::inverse::design::{DesignConfig, DesignError, design_inverse};
use crate::model::params::{ParamName, Params};
use crate::numeric::real::Real;

/// RH step [%] of the load-time design check over the declared range (both ends included).
pub const DESIGN_CHECK_STEP_PCT: f64 = 5.0;

/// Why a calibration file was refused. Displayed as `line:column: what`, or the parameter and RH
/// that make the laws unusable; the caller puts the file name in front.
#[derive(Clone, Debug, PartialEq)]
pub enum FileError {
    /// Not TOML, or not the shape of a calibration: 1-based line and column of the offending text.
    Syntax { line: usize, column: usize, message: String },
    /// Well formed, but not physical somewhere on its declared range.
    Invalid(ValidationError),
    /// Positive and finite, but the firmware's inverse cannot be designed at this RH (magnitudes
    /// far from any IPMC strip). `farthest` is the parameter most orders of magnitude away from
    /// the default preset there, with its value: the likely culprit.
    Undesignable { rh_pct: f64, error: DesignError, farthest: ParamName, value: f64 },
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FileError::Syntax { line, column, message } => write!(f, "{line}:{column}: {}", message.trim_end()),
            FileError::Invalid(e) => write!(f, "calibration is not usable: {e}"),
            FileError::Undesignable { rh_pct, error, farthest, value } => write!(
                f,
                "calibration is not usable: no inverse at RH {rh_pct:.1} % ({error}); parameter {} = {value:e} {} \
                 is the farthest from the default preset there",
                farthest.as_str(),
                farthest.unit()
            ),
        }
    }
}

impl std::error::Error for FileError {}

/// Parses and validates a calibration file's text, and checks that the firmware can design
/// with it over its declared range.
pub fn parse(text: &str) -> Result<Calibration, FileError> {
    let calibration = parse_unvalidated(text)?;
    check(&calibration)?;
    Ok(calibration)
}

/// What loading requires of any calibration (file or preset): physical laws on the declared
/// range, and the firmware's f32 inverse designable every [`DESIGN_CHECK_STEP_PCT`] % of the
/// humidities it designs at ([`Calibration::design_range`]: the laws' continuation past the
/// range included).
pub fn check(c: &Calibration) -> Result<(), FileError> {
    c.validate().map_err(FileError::Invalid)?;
    let (lo, hi) = c.design_range();
    let steps = Real::ceil((hi - lo) / DESIGN_CHECK_STEP_PCT) as usize;
    for i in 0..=steps {
        let rh = (lo + i as f64 * DESIGN_CHECK_STEP_PCT).min(hi);
        if let Err(error) = design_inverse(c, rh as f32, &DesignConfig::<f32>::default()) {
            let (farthest, value) = farthest_from_default(&c.params_at(rh), rh);
            return Err(FileError::Undesignable { rh_pct: rh, error, farthest, value });
        }
    }
    Ok(())
}

/// The parameter whose ratio to the default preset's value at `rh` is largest in magnitude
/// of its logarithm, and its value.
fn farthest_from_default(p: &Params<f64>, rh: f64) -> (ParamName, f64) {
    let reference: Params<f64> = Calibration::default_preset().params_at(rh);
    let off = |n: ParamName| Real::abs(Real::ln(p.get(n) / reference.get(n)));
    let worst = ParamName::ALL.iter().copied().fold(ParamName::Y, |w, n| if off(n) > off(w) { n } else { w });
    (worst, p.get(worst))
}

/// Parses without validating (a verbatim preset that validation refuses still reads back). The
/// `[checked]` table, what checks left unknown of the strip, is read apart ([`checked`]).
pub fn parse_unvalidated(text: &str) -> Result<Calibration, FileError> {
    let text = &split_checked(text, false);
    toml::from_str(text).map_err(|e| syntax_error(text, &e, "`name = number` lines, `[y]`…`[m]` law tables and `coeffs = [numbers]`"))
}

/// The file's `[checked]` table (written by `ipmc recalibrate`), None where it has none.
pub fn checked(text: &str) -> Result<Option<Checked>, FileError> {
    #[derive(serde::Deserialize)]
    struct Only {
        checked: Option<Checked>,
    }
    let text = &split_checked(text, true);
    toml::from_str::<Only>(text)
        .map(|o| o.checked)
        .map_err(|e| syntax_error(text, &e, "`rh_pct = [numbers]`, `axes = [[7 numbers], …]` and `drift_sd = [7 numbers]`"))
}

/// `text` with the lines of its `[checked]` table (`keep`: every other line) blanked, their
/// line endings kept, so that either part reads with the file's own line numbers.
fn split_checked(text: &str, keep: bool) -> String {
    let mut inside = false;
    let mut out = String::with_capacity(text.len());
    for line in text.split_inclusive('\n') {
        if let Some(name) = header_name(line) {
            inside = name == CHECKED_TABLE;
        }
        match inside == keep {
            true => out.push_str(line),
            false => out.push_str(&line[line.trim_end_matches(['\r', '\n']).len()..]),
        }
    }
    out
}

/// The name of the table [`checked`] reads.
pub const CHECKED_TABLE: &str = "checked";

/// The `[checked]` table's text, to follow a calibration's ([`to_text`]).
pub fn checked_text(c: &Checked) -> String {
    #[derive(serde::Serialize)]
    struct Only<'a> {
        checked: &'a Checked,
    }
    toml::to_string(&Only { checked: c }).unwrap_or_default()
}

/// A toml error on `text` as a located [`FileError::Syntax`] (the tool's other TOML files use it
/// too). toml's grammar errors come without a message: they get "not valid TOML here: expected "
/// and `shape`, what the file should look like.
pub fn syntax_error(text: &str, e: &toml::de::Error, shape: &str) -> FileError {
    // toml gives a top-level key that is missing no span: the document, from its start, is at fault.
    let start = e.span().map_or(0, |s| s.start);
    let (line, column) = line_col(text, start);
    let message = match e.message().trim() {
        "" => format!("not valid TOML here: expected {shape}"),
        // toml locates a key missing from a table at the table's header but names only the key;
        // in a file of many tables with the same keys (`kind`, `coeffs`) the table is the news.
        m => match table_at(text, start) {
            Some(table) => format!("{m} in table `[{table}]`"),
            None => format!("{m} (at the top level, before any `[table]`)"),
        },
    };
    FileError::Syntax { line, column, message }
}

/// The name of the `[table]` (or `[[array]]`) whose header is the last one at or before byte
/// `offset` of `text`; None at the top level.
fn table_at(text: &str, offset: usize) -> Option<&str> {
    let (line, _) = line_col(text, offset);
    text.lines().take(line).filter_map(header_name).last()
}

/// `y` of a header line `[y]`, `a.b` of `[[a.b]]`; None for any other line (a value's array
/// starts with `[` after `=`, never at the line's start with a closing `]` and nothing after).
fn header_name(line: &str) -> Option<&str> {
    let line = line.split('#').next()?.trim();
    let inner = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")).or_else(|| line.strip_prefix('[')?.strip_suffix(']'))?;
    let name = inner.trim();
    let bare = |c: char| c.is_ascii_alphanumeric() || "_-.\"' ".contains(c);
    (!name.is_empty() && name.chars().all(bare)).then_some(name)
}

/// The file's text for `c`.
pub fn to_text(c: &Calibration) -> String {
    // Every field is a number, a string or an array of numbers: serialization cannot fail.
    toml::to_string(c).unwrap_or_default()
}

/// 1-based line and column (in characters) of byte `offset` of `text`.
fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let mut end = offset.min(text.len());
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let before = &text[..end];
    let line = before.matches('\n').count() + 1;
    let column = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
    (line, column)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_positions() {
        let c = Calibration::default_preset();
        let text = to_text(&c);
        assert_eq!(parse(&text), Ok(c));
        let bad = text.replacen("t_k = 293.0", "t_k = \"warm\"", 1);
        let line = bad.lines().position(|l| l.starts_with("t_k")).unwrap() + 1;
        match parse(&bad) {
            Err(FileError::Syntax { line: l, column, message }) => {
                assert_eq!((l, column), (line, 7), "{message}");
                assert!(message.contains("expected"), "{message}");
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(line_col("aé\nb", 2), (1, 2)); // inside a character: its start
    }

    #[test]
    fn the_humidity_table_is_optional_checked_and_kept() {
        use crate::calibration::humidity_path::{HumidityPath, SensorKind};
        let plain = to_text(&Calibration::default_preset());
        let old = plain.split("[humidity]").next().unwrap().to_string();
        assert!(!old.contains("[humidity]"));
        assert_eq!(parse(&old).unwrap().humidity, HumidityPath::NONE, "files from before the table");
        let mut c = Calibration::default_preset();
        c.humidity = HumidityPath {
            sensor: Some(SensorKind::Hts221),
            offset_pct: 2.5,
            gain: 0.98,
            tau_wet_s: 600.0,
            tau_dry_s: 900.0,
            uncertainty_pct: Some(1.2),
            sensor_lag_s: Some(4.0),
            mode: Some(crate::calibration::humidity_path::HumidityMode::Fused),
            supply_v: Some(4.85),
            lag_offsets: None,
        };
        let text = to_text(&c);
        assert!(text.contains("[humidity]") && text.contains("sensor = \"hts221\""), "{text}");
        assert!(text.contains("supply_v = 4.85") && !plain.contains("supply_v"), "written when set only: {text}");
        assert_eq!(parse(&text), Ok(c));
        let only = old.clone() + "\n[humidity]\ntau_wet_s = 300.0\n";
        let p = parse(&only).unwrap().humidity;
        assert_eq!((p.tau_wet_s, p.tau_dry_s, p.gain, p.offset_pct), (300.0, 0.0, 1.0, 0.0), "unset keys keep their defaults");
        // `mode`: not set is not `reading`; the default applies only where nobody chose.
        use crate::calibration::humidity_path::HumidityMode;
        assert_eq!((p.mode, p.mode()), (None, HumidityMode::DEFAULT));
        assert!(!to_text(&Calibration::default_preset()).contains("mode ="), "not chosen, not written");
        let chosen = parse(&(only.clone() + "mode = \"reading\"\n")).unwrap().humidity;
        assert_eq!((chosen.mode, chosen.mode()), (Some(HumidityMode::Reading), HumidityMode::Reading));
        assert!(to_text(&parse(&(only.clone() + "mode = \"reading\"\n")).unwrap()).contains("mode = \"reading\""));
        for (bad, key) in [
            ("tau_wet_s = -5.0", "humidity.tau_wet_s"),
            ("gain = 0.0", "humidity.gain"),
            ("offset_pct = 25.0", "humidity.offset_pct"),
            ("supply_v = 12.0", "humidity.supply_v"),
        ] {
            let e = parse(&format!("{old}\n[humidity]\n{bad}\n")).unwrap_err().to_string();
            assert!(e.contains(key), "{bad}: {e}");
        }
        let e = parse(&format!("{old}\n[humidity]\nsensor = \"dht22\"\n")).unwrap_err();
        assert!(matches!(e, FileError::Syntax { .. }), "{e}");
    }

    /// The offsets a check found given each hydration lag: written as the grid's lags with one
    /// offset and one 1σ each, read back the same; a table for other lags, of another length
    /// or out of range is refused, naming the key.
    #[test]
    fn the_lag_offsets_are_kept_and_checked() {
        use crate::calibration::lag_offsets::{HYDRATION_LAGS_S, LagOffsets};
        let mut c = Calibration::default_preset();
        c.humidity.offset_pct = 0.9;
        c.humidity.uncertainty_pct = Some(0.3);
        c.humidity.lag_offsets = Some(LagOffsets {
            offset_pct: [-0.46, -0.14, 0.12, 0.23, 0.28],
            sd_pct: [0.05, 0.05, 0.06, 0.07, 0.08],
            weight: [0.1, 0.5, 0.25, 0.1, 0.05],
            between: [0.0, 0.8, 0.2, 0.0],
        });
        let text = to_text(&c);
        assert!(text.contains("[humidity.lag_offsets]") && text.contains("lag_s = [10.0, 20.0, 40.0, 80.0, 160.0]"), "{text}");
        assert_eq!(parse(&text), Ok(c));
        let plain = to_text(&Calibration::default_preset());
        assert!(!plain.contains("lag_offsets"), "written when set only");
        let with = |table: &str| parse(&format!("{plain}\n[humidity.lag_offsets]\n{table}\n"));
        let grid = format!("lag_s = {HYDRATION_LAGS_S:?}");
        let other = with("lag_s = [10.0, 30.0, 90.0, 270.0, 810.0]\noffset_pct = [0, 0, 0, 0, 0]\nsd_pct = [1, 1, 1, 1, 1]");
        assert!(other.unwrap_err().to_string().contains("recalibrate"));
        let short = with(&format!("{grid}\noffset_pct = [0, 0, 0]\nsd_pct = [1, 1, 1, 1, 1]"));
        assert!(short.unwrap_err().to_string().contains("one number per lag"));
        let zero = with(&format!("{grid}\noffset_pct = [0, 0, 0, 0, 0]\nsd_pct = [1, 1, 0, 1, 1]"));
        assert!(zero.unwrap_err().to_string().contains("humidity.lag_offsets.sd_pct = 0"));
        let far = with(&format!("{grid}\noffset_pct = [0, 25, 0, 0, 0]\nsd_pct = [1, 1, 1, 1, 1]"));
        assert!(far.unwrap_err().to_string().contains("humidity.lag_offsets.offset_pct = 25"));
        // Without weights (a table whose checks did not weigh the lags), equal ones.
        let equal = with(&format!("{grid}\noffset_pct = [0, 0, 0, 0, 0]\nsd_pct = [1, 1, 1, 1, 1]")).unwrap();
        assert_eq!(equal.humidity.lag_offsets.unwrap().weight, crate::calibration::lag_offsets::EQUAL_WEIGHTS);
        let unnormed = with(&format!("{grid}\noffset_pct = [0, 0, 0, 0, 0]\nsd_pct = [1, 1, 1, 1, 1]\nweight = [1, 1, 1, 1, 1]"));
        assert!(unnormed.unwrap_err().to_string().contains("humidity.lag_offsets.weight"));
        // Without `between` (a table whose course did not read the lag finer), none.
        assert_eq!(equal.humidity.lag_offsets.unwrap().between, crate::calibration::lag_offsets::NONE_BETWEEN);
        let beyond = with(&format!("{grid}\noffset_pct = [0, 0, 0, 0, 0]\nsd_pct = [1, 1, 1, 1, 1]\nbetween = [0, -0.5, 0, 0]"));
        assert!(beyond.unwrap_err().to_string().contains("between"));
    }

    #[test]
    fn the_checked_table_is_read_apart_and_kept() {
        use crate::calibration::checked::Checked;
        let c = Calibration::default_preset();
        let plain = to_text(&c);
        assert_eq!(checked(&plain), Ok(None));
        let t = Checked::new(&[71.5, 64.0], &[[0.01, 0.0, -0.02, 0.0, 0.1, 0.0, 0.0]], [0.0, 0.0, 0.0, 0.2, 0.18, 0.0, 0.0]).unwrap();
        let text = format!("{plain}\n{}\n[band]\nlow_hz = 12.0\nhigh_hz = 150.0\n", checked_text(&t)).replacen("[band]", "[former]", 1);
        let text = text.replace("[former]\n", "").replacen("low_hz = 10.0\nhigh_hz = 150.0\nshape = \"linear-phase\"\n", "", 1);
        assert_eq!(checked(&text), Ok(Some(t)), "{text}");
        assert_eq!(parse(&text).unwrap().band.low_hz, 12.0, "a table after `[checked]` is the calibration's: {text}");
        // Errors keep the file's own line numbers.
        let bad = format!("{plain}\n[checked]\nrh_pct = [71.5]\naxes = [[0.0, 0.0]]\ndrift_sd = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]\n");
        let line = bad.lines().position(|l| l.starts_with("axes")).unwrap() + 1;
        assert!(matches!(checked(&bad), Err(FileError::Syntax { line: l, .. }) if l == line), "{:?}", checked(&bad));
        assert!(parse(&bad).is_ok(), "the calibration reads without it");
        let far = bad.replace("axes = [[0.0, 0.0]]", "axes = []").replace("[71.5]", "[171.5]");
        assert!(checked(&far).unwrap_err().to_string().contains("checked.rh_pct"), "{:?}", checked(&far));
    }

    #[test]
    fn band_departures_and_instrument_are_optional_checked_and_kept() {
        use crate::band::Band;
        use crate::calibration::departures::Departures;
        use crate::calibration::instrument::Instrument;
        let plain = to_text(&Calibration::default_preset());
        assert!(!plain.contains("[departures]"), "no table, no key: {plain}");
        let old = plain.split("[humidity]").next().unwrap().to_string();
        let c = parse(&old).unwrap();
        assert_eq!((c.band, c.departures, c.instrument), (Band::DEFAULT, Departures::NONE, Instrument::DATASHEET));
        let mut c = Calibration::default_preset();
        c.band = Band { low_hz: 12.0, high_hz: 200.0, ..Band::DEFAULT };
        c.instrument.tip_gain = 1.006;
        c.departures = Departures::new(&[40.0, 60.0], [&[0.05, -0.02], &[0.0, 0.1], &[0.0, 0.0], &[-0.1, 0.2]]).unwrap();
        let text = to_text(&c);
        assert!(text.contains("[departures]") && text.contains("[band]") && text.contains("[instrument]"), "{text}");
        c.band.shape = crate::band::Shape::LowLatency;
        let text = to_text(&c);
        assert!(text.contains("shape = \"low-latency\""), "{text}");
        assert_eq!(parse(&text).unwrap(), c);
        let without = old.replace("shape = \"linear-phase\"\n", "");
        assert_eq!(parse(&without).unwrap().band, Band::DEFAULT, "files from before the key: linear phase");
        let back = parse(&text).unwrap();
        assert_eq!(back, c);
        let moved = |p: &Calibration| p.params_at(60.0_f64).cs / p.laws_at(60.0_f64).cs;
        assert!((moved(&back) - 0.1_f64.exp()).abs() < 1e-12, "the table reaches params_at");
        for (table, bad, key) in [
            ("band", "low_hz = 200.0\nhigh_hz = 100.0", "band.high_hz"),
            ("instrument", "tip_gain = 3.0", "instrument.tip_gain"),
            ("instrument", "acquisition_delay_us = -1.0", "instrument.acquisition_delay_us"),
            ("departures", "rh_pct = [40.0, 50.0]\ny = [0.0, 0.0]\ncs = [0.0]\nca = [0.0, 0.0]\nd = [0.0, 0.0]", "departures.cs"),
            ("departures", "rh_pct = [50.0, 40.0]\ny = [0.0, 0.0]\ncs = [0.0, 0.0]\nca = [0.0, 0.0]\nd = [0.0, 0.0]", "departures.rh_pct"),
        ] {
            let e = parse(&format!("{old}\n[{table}]\n{bad}\n")).unwrap_err().to_string();
            assert!(e.contains(key), "{bad}: {e}");
        }
    }

    /// Every law table has `kind` and `coeffs`: "missing field `coeffs`" alone does not say
    /// which of seven tables lacks it.
    #[test]
    fn a_key_missing_in_a_table_names_the_table_and_its_line() {
        let text = to_text(&Calibration::default_preset());
        let header = text.lines().position(|l| l == "[d]").expect("a [d] table") + 1;
        let start = text.find("[d]\n").unwrap();
        let coeffs = start + text[start..].find("coeffs").unwrap();
        let mut bad = text.clone();
        bad.replace_range(coeffs..coeffs + text[coeffs..].find('\n').unwrap() + 1, "");
        let e = parse(&bad).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{header}:")), "{e}");
        assert!(e.contains("`coeffs`") && e.contains("table `[d]`"), "{e}");
        let e = parse(&text.replacen("t_k = 293.0\n", "", 1)).unwrap_err().to_string();
        assert!(e.contains("`t_k`") && e.contains("top level"), "{e}");
        assert_eq!(header_name("[[a.b]] # note"), Some("a.b"));
        assert_eq!(header_name("coeffs = [1.0]"), None);
    }

    #[test]
    fn unknown_fields_are_refused() {
        let text = to_text(&Calibration::default_preset()) + "rh_maximum = 95.0\n";
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains("rh_maximum"), "{e}");
    }

    #[test]
    fn paper_preset_reads_back_but_is_refused_naming_d() {
        let text = to_text(&Calibration::paper());
        assert_eq!(parse_unvalidated(&text), Ok(Calibration::paper()));
        let e = parse(&text).unwrap_err().to_string();
        assert!(e.contains("parameter d ") && e.contains("RH 38.0"), "{e}");
    }

    #[test]
    fn absurd_magnitudes_are_refused_naming_rh_and_parameter() {
        let mut c = Calibration::default_preset();
        c.validate().unwrap();
        c.set(ParamName::L, 6.6e22);
        c.validate().unwrap(); // positive and finite: the laws alone do not catch it
        let e = check(&c).unwrap_err();
        assert!(matches!(e, FileError::Undesignable { farthest: ParamName::L, .. }), "{e}");
        let shown = e.to_string();
        // The first humidity checked is the design range's lower end, 2 %RH below the declared 20.
        assert!(shown.contains("RH 18.0 %") && shown.contains("parameter L = 6.6e22 m"), "{shown}");
    }
}
