//! Follow-ups of a case (recording-format.md, "Follow-up recordings"): the measurement a
//! diagnosis that cannot decide asks for, made of the case's strip ([`CaseStrip`]) in a new
//! session of the one simulator. Each protocol is the primary's session changed where the
//! protocol says; the strip, its effect and the instrument stay:
//!
//! - `wideband`: a frequency response to 2 kHz at 40, 53, 67 and 80 %RH, the shaker driven harder
//!   above the primary's band (the amplifier's and the electrodes' poles, a delay and the higher
//!   modes show there);
//! - `step`: bursts while each level of 45→60→75→60→45 %RH settles (a hydration lag keeps the
//!   strip changing after the chamber has arrived; a sensor offset shifts the readings alone);
//! - `temperature`: the primary's layout with the room held at 30 °C;
//! - `reference`: the humidity sensor in saturated-salt jars.

use super::concealed::{Case, CaseStrip, FREQS, Format};
use crate::recordings::{Recording, humidity_reference, simulate};
use crate::session::{Session, log_spaced};
use ipmc_core::Calibration;
use ipmc_fit::random::SplitMix64;
use ipmc_recording::{Followup, HumidityReference, Metadata, Protocol, SETPOINTS_KEY, SetpointForm, setpoints_text};

/// The wideband session's levels [%RH], up only.
pub const WIDEBAND_LEVELS_PCT: [f64; 4] = [40.0, 53.0, 67.0, 80.0];
/// Log-spaced frequencies above the primary's band, up to [`WIDEBAND_TOP_HZ`].
pub const WIDEBAND_EXTRA_POINTS: usize = 40;
pub const WIDEBAND_TOP_HZ: f64 = 2000.0;
/// Above the primary's band the shaker is allowed this many times the acceleration it has at
/// the band's top (200 against 50 m/s²), so that the top octave still carries signal.
const WIDEBAND_ACCELERATION_RAISE: f64 = 4.0;

/// The step session's levels [%RH].
pub const STEP_LEVELS_PCT: [f64; 5] = [45.0, 60.0, 75.0, 60.0, 45.0];
/// Bursts start these times after each step [s]: dense while the chamber approaches (its τ is
/// 30 s), sparse while only a slow lag of the strip can still be moving.
pub const STEP_BURSTS_AFTER_S: [f64; 6] = [5.0, 15.0, 40.0, 90.0, 200.0, 400.0];
/// Each level is held this long, plus up to [`STEP_HOLD_JITTER_S`] [s].
const STEP_HOLD_S: f64 = 600.0;
const STEP_HOLD_JITTER_S: f64 = 60.0;
/// One period of the multisine (its lines are on a 1 Hz grid).
const STEP_BURST_S: f64 = 1.0;

/// The room during the temperature session [°C], held within ±[`TEMPERATURE_HELD_K`].
pub const TEMPERATURE_ROOM_C: f64 = 30.0;
const TEMPERATURE_HELD_K: f64 = 0.3;

/// A follow-up: a recording of §1 or §2, or a humidity reference (§4).
pub enum FollowupRecording {
    Recording(Recording),
    Reference(HumidityReference),
}

impl FollowupRecording {
    pub fn to_csv(&self) -> anyhow::Result<String> {
        match self {
            FollowupRecording::Recording(r) => r.to_csv(),
            FollowupRecording::Reference(r) => Ok(r.to_csv()?),
        }
    }
}

/// The follow-up of `case` by `protocol`, naming `primary_name` (the file the case's recording
/// was written to) as its strip. `seed` draws the session: another seed, another session of the
/// same strip.
pub fn make_followup(
    calib: &Calibration,
    case: &Case,
    protocol: Protocol,
    primary_name: &str,
    seed: u64,
) -> anyhow::Result<FollowupRecording> {
    let strip = &case.strip;
    // The strip's identity and the protocol enter the session's seed: follow-ups of different
    // strips or by different protocols never share their noise.
    let mut rng = SplitMix64(seed ^ strip.strip_seed.rotate_left(23) ^ (protocol as u64 + 1).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    let session_seed = rng.uniform().to_bits();
    let mut metadata = Metadata::default();
    metadata.set("generator", format!("ipmc prove follow-up seed={seed}"));
    Followup { protocol, strip: primary_name.to_string() }.write(&mut metadata);
    metadata.set("session", "new: the same strip and instrument as the primary recording, measured again");
    let session = match protocol {
        Protocol::Wideband => wideband(calib, strip, session_seed, &mut metadata),
        Protocol::Step => step(calib, strip, session_seed, &mut metadata),
        Protocol::Temperature => temperature(calib, strip, session_seed, &mut metadata),
        Protocol::Reference => {
            let session = strip.session(calib, strip.format, session_seed);
            return Ok(FollowupRecording::Reference(humidity_reference::simulate(&session, metadata)));
        }
    };
    session.validate()?;
    Ok(FollowupRecording::Recording(simulate(calib, &session, &strip.physics, metadata)?))
}

fn levels_text(levels: &[f64]) -> String {
    levels.iter().map(|l| format!("{l:.0}")).collect::<Vec<_>>().join(",")
}

/// A frequency response whatever the primary's format: a time series' bursts would need a
/// sampling rate above 4 kHz.
fn wideband(calib: &Calibration, strip: &CaseStrip, seed: u64, metadata: &mut Metadata) -> Session {
    let mut s = strip.session(calib, Format::Fr, seed);
    let band_top = FREQS[FREQS.len() - 1];
    let mut freqs = FREQS.to_vec();
    freqs.extend(log_spaced(band_top, WIDEBAND_TOP_HZ, WIDEBAND_EXTRA_POINTS + 1).into_iter().skip(1));
    s.humidity.levels_pct = WIDEBAND_LEVELS_PCT.to_vec();
    let plan = s.frequencies.as_mut().expect("a frequency-response session");
    plan.list_hz = Some(freqs);
    // The base's amplitude stays the primary's until the raised acceleration limit meets it.
    plan.full_amplitude_to_hz = Some(band_top * WIDEBAND_ACCELERATION_RAISE.sqrt());
    s.noise.current_floor_band_hz = Some([FREQS[0], band_top]);
    metadata.set(SETPOINTS_KEY, setpoints_text(&WIDEBAND_LEVELS_PCT, SetpointForm::Up));
    metadata.set(
        "band",
        format!(
            "as the primary to {band_top:.0} Hz, then {WIDEBAND_EXTRA_POINTS} log-spaced points to {WIDEBAND_TOP_HZ:.0} Hz; \
             above {band_top:.0} Hz the base driven at {WIDEBAND_ACCELERATION_RAISE:.0}x the acceleration"
        ),
    );
    s
}

fn step(calib: &Calibration, strip: &CaseStrip, seed: u64, metadata: &mut Metadata) -> Session {
    let mut s = strip.session(calib, Format::Ts, seed);
    s.humidity.levels_pct = STEP_LEVELS_PCT.to_vec();
    s.humidity.settle_s = STEP_HOLD_S;
    s.humidity.settle_jitter_s = STEP_HOLD_JITTER_S;
    let plan = s.time_series.as_mut().expect("a time-series session");
    plan.burst_s = STEP_BURST_S;
    plan.bursts_after_step_s = Some(STEP_BURSTS_AFTER_S.to_vec());
    metadata.set(SETPOINTS_KEY, setpoints_text(&STEP_LEVELS_PCT, SetpointForm::Steps));
    metadata.set(
        "timing",
        format!(
            "each level held {STEP_HOLD_S:.0}-{:.0} s; {STEP_BURST_S} s bursts start {} s after each step (first level: one, at {:.0} s)",
            STEP_HOLD_S + STEP_HOLD_JITTER_S,
            levels_text(&STEP_BURSTS_AFTER_S),
            STEP_BURSTS_AFTER_S[STEP_BURSTS_AFTER_S.len() - 1]
        ),
    );
    s
}

fn temperature(calib: &Calibration, strip: &CaseStrip, seed: u64, metadata: &mut Metadata) -> Session {
    let mut s = strip.session(calib, strip.format, seed);
    s.temp_c = Some(TEMPERATURE_ROOM_C);
    s.temp_swing_k = TEMPERATURE_HELD_K;
    metadata.set("room_c", format!("{TEMPERATURE_ROOM_C:.0} (held within +-{TEMPERATURE_HELD_K} C)"));
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::proof::concealed::{Strength, make_case};
    use ipmc_core::model::exact::{current_response, jw};
    use ipmc_diagnose::Effect;
    use ipmc_recording::{Format as _, FrequencyResponse, TimeSeries};

    const PRIMARY: &str = "case07.csv";

    fn case(effect: Option<Effect>, seed: u64, format: Format) -> Case {
        make_case(&Calibration::default_preset(), effect, seed, Strength::At(0.8), format).unwrap()
    }

    fn followup_csv(case: &Case, protocol: Protocol, seed: u64) -> String {
        make_followup(&Calibration::default_preset(), case, protocol, PRIMARY, seed).unwrap().to_csv().unwrap()
    }

    fn is_followup(metadata: &Metadata, protocol: Protocol) {
        let f = Followup::of(metadata, "f.csv").unwrap();
        assert_eq!(f, Some(Followup { protocol, strip: PRIMARY.into() }));
    }

    /// Each protocol's file reads back through the interchange format's readers as a follow-up of
    /// the primary, in the layout the protocol defines, whichever format the primary was.
    #[test]
    fn each_protocol_reads_back_in_its_layout() {
        for format in [Format::Fr, Format::Ts] {
            let case = case(None, 3, format);
            let primary_levels = case.strip.levels_pct.len();

            let (fr, _) = FrequencyResponse::parse("w.csv", &followup_csv(&case, Protocol::Wideband, 1)).unwrap();
            is_followup(&fr.metadata, Protocol::Wideband);
            let levels = fr.levels();
            assert_eq!(levels.len(), WIDEBAND_LEVELS_PCT.len());
            for (l, want) in levels.iter().zip(WIDEBAND_LEVELS_PCT) {
                assert!((l.rh_pct - want).abs() < 2.5, "{} for {want}", l.rh_pct);
                assert_eq!(l.points.len(), FREQS.len() + WIDEBAND_EXTRA_POINTS);
                assert_eq!(l.points[0].freq_hz, FREQS[0]);
                assert!((l.points[l.points.len() - 1].freq_hz - WIDEBAND_TOP_HZ).abs() < 1e-9);
            }

            let (ts, _) = TimeSeries::parse("s.csv", &followup_csv(&case, Protocol::Step, 1)).unwrap();
            is_followup(&ts.metadata, Protocol::Step);
            let bursts = ts.bursts();
            assert_eq!(bursts.len(), 1 + (STEP_LEVELS_PCT.len() - 1) * STEP_BURSTS_AFTER_S.len());
            assert!(bursts.iter().all(|b| b.len() as f64 == STEP_BURST_S * ts.fs_hz));
            assert_eq!(ts.t_s[0], STEP_BURSTS_AFTER_S[5]);
            // The second level's bursts follow the chamber's approach: short of the level 5 s
            // after the step (τ 30 s from 45 %RH), there within its errors 400 s after.
            let mean_rh = |b: &std::ops::Range<usize>| ts.rh_pct[b.clone()].iter().sum::<f64>() / b.len() as f64;
            assert!(mean_rh(&bursts[1]) < 55.0, "{}", mean_rh(&bursts[1]));
            assert!((mean_rh(&bursts[6]) - 60.0).abs() < 2.5, "{}", mean_rh(&bursts[6]));

            let text = followup_csv(&case, Protocol::Temperature, 1);
            let temps = match format {
                Format::Fr => {
                    let (fr, _) = FrequencyResponse::parse("t.csv", &text).unwrap();
                    is_followup(&fr.metadata, Protocol::Temperature);
                    assert_eq!(fr.points.len(), primary_levels * FREQS.len());
                    fr.points.iter().map(|p| p.temp_c.unwrap()).collect::<Vec<_>>()
                }
                Format::Ts => {
                    let (ts, _) = TimeSeries::parse("t.csv", &text).unwrap();
                    is_followup(&ts.metadata, Protocol::Temperature);
                    assert_eq!(ts.bursts().len(), primary_levels);
                    ts.temp_c.unwrap()
                }
            };
            // Held within ±0.3 K, read with 0.1 K of error.
            assert!(temps.iter().all(|t| (t - TEMPERATURE_ROOM_C).abs() < 0.8), "{format:?}");

            let (r, _) = HumidityReference::parse("r.csv", &followup_csv(&case, Protocol::Reference, 1)).unwrap();
            is_followup(&r.metadata, Protocol::Reference);
            assert_eq!((r.reference.as_str(), r.reference_uncertainty_pct), ("saturated salts", 0.3));
            assert_eq!(r.references(), vec![32.8, 43.2, 75.3]);
            assert_eq!(r.rh_pct.len(), 3 * humidity_reference::READINGS_PER_SALT);
        }
    }

    /// ln(measured current / the calibration's at the level's mean reading), averaged over the
    /// primary's band above the first resonance: where the strip departs from its calibration
    /// (its drift and scatter), per level.
    fn departures(fr: &FrequencyResponse) -> Vec<(f64, f64)> {
        let calib = Calibration::default_preset();
        fr.levels()
            .iter()
            .map(|l| {
                let p = calib.params_at(l.rh_pct);
                let ln: Vec<f64> = l
                    .points
                    .iter()
                    .filter(|pt| (45.0..=150.0).contains(&pt.freq_hz))
                    .map(|pt| (pt.current.unwrap().gain / current_response(&p, jw(pt.freq_hz)).norm()).ln())
                    .collect();
                (l.rh_pct, ln.iter().sum::<f64>() / ln.len() as f64)
            })
            .collect()
    }

    fn wideband(case: &Case, seed: u64) -> FrequencyResponse {
        FrequencyResponse::parse("w.csv", &followup_csv(case, Protocol::Wideband, seed)).unwrap().0
    }

    /// Same strip, new session: a clean strip whose primary starts at 40 %RH departs from its
    /// calibration there as its wideband follow-up does at 40 %RH, and two follow-ups (two
    /// seeds, two sessions: other bytes) agree at every level; another strip departs otherwise
    /// (its own drift, 15 % in Cs, Ca and d). Within 4 %: the noise averages to a few tenths of
    /// a percent, but the chamber settles ±0.7 %RH about each setpoint and the strip's own
    /// scatter changes by about 3 % per %RH.
    #[test]
    fn a_followup_measures_the_same_strip_in_a_new_session() {
        const WITHIN: f64 = 0.04;
        let from_40 = (1..200).map(|s| case(None, s, Format::Fr)).find(|c| (c.strip.levels_pct[0] - 40.0).abs() < 0.3).unwrap();
        let primary = FrequencyResponse::parse(PRIMARY, &from_40.recording.to_csv().unwrap()).unwrap().0;
        let (a, b) = (wideband(&from_40, 1), wideband(&from_40, 2));
        assert_ne!(a, b, "a new seed is a new session");
        let (da, db, dp) = (departures(&a), departures(&b), departures(&primary));
        for (x, y) in da.iter().zip(&db) {
            assert!((x.1 - y.1).abs() < WITHIN, "{x:?} against {y:?}");
        }
        assert!((dp[0].1 - da[0].1).abs() < WITHIN, "primary {:?}, follow-up {:?}", dp[0], da[0]);
        let other = departures(&wideband(&case(None, 1000, Format::Fr), 1));
        let apart = da.iter().zip(&other).map(|(x, y)| (x.1 - y.1).abs()).fold(0.0, f64::max);
        assert!(apart > 2.0 * WITHIN, "another strip departs by at most {apart}");
    }

    /// The step follow-up separates a hydration lag from a sensor offset: 200 and 400 s after
    /// the step to 60 %RH the chamber has long arrived (τ 30 s), so a clean strip's current is
    /// the same in both bursts (within its noise and the chamber's wander), an offset sensor's
    /// too (their current changes by 0.1–0.2 % here), while a lagging strip (τ ≈ 400 s at this
    /// strength) is still wetting between them (2.5 %: the current's rms is dominated by lines
    /// that depend on humidity less than the 10 Hz one).
    #[test]
    fn a_hydration_lag_keeps_changing_after_the_chamber_has_arrived() {
        for (effect, changing) in [(Some(Effect::HydrationLag), true), (Some(Effect::HumiditySensorError), false), (None, false)] {
            let (ts, _) = TimeSeries::parse("s.csv", &followup_csv(&case(effect, 7, Format::Fr), Protocol::Step, 1)).unwrap();
            let bursts = ts.bursts();
            let rms = |b: &std::ops::Range<usize>| (ts.current_a[b.clone()].iter().map(|i| i * i).sum::<f64>() / b.len() as f64).sqrt();
            let change = (rms(&bursts[6]) / rms(&bursts[5])).ln();
            assert_eq!(change > 0.01, changing, "{effect:?}: ln(rms at 400 s / rms at 200 s) = {change:.4}");
        }
    }

    /// The reference follow-up shows the humidity sensor's drawn error, and a clean bench's
    /// sensor reads the salts within their uncertainty and its noise (3σ).
    #[test]
    fn the_reference_shows_the_sensors_error() {
        let calib = Calibration::default_preset();
        for effect in [Some(Effect::HumiditySensorError), None] {
            let case = case(effect, 7, Format::Fr);
            let (r, _) = HumidityReference::parse("r.csv", &followup_csv(&case, Protocol::Reference, 1)).unwrap();
            let n = r.rh_pct.len() as f64;
            let (gain, offset) = (case.strip.bench.sensor_gain, case.strip.bench.sensor_offset_pct);
            let read_error = case.strip.session(&calib, Format::Fr, 0).humidity.read_error_pct;
            let error = r.rh_pct.iter().zip(&r.reference_rh_pct).map(|(read, reference)| read - reference).sum::<f64>() / n;
            let drawn = r.reference_rh_pct.iter().map(|reference| (gain - 1.0) * reference + offset).sum::<f64>() / n;
            let salts = r.references().len() as f64;
            let sigma = (read_error.powi(2) / n + (gain * r.reference_uncertainty_pct).powi(2) / salts).sqrt();
            assert!((error - drawn).abs() < 3.0 * sigma, "{effect:?}: read {error:+.2} %RH off, drawn {drawn:+.2} (σ {sigma:.2})");
            assert_eq!(error.abs() > 3.0 * sigma, effect.is_some(), "{effect:?}: {error:+.2} %RH (σ {sigma:.2})");
        }
    }
}
