//! The recordings as `diagnose` fits them: humidity levels of complex responses per frequency,
//! each with the time, temperature and session it was measured in.

use ipmc_core::calibration::humidity_path::HumidityPath;
use ipmc_recording::FrequencyResponse;

/// One visit of one humidity level: fit's, which every fit takes (its `revisit_of` indexes the
/// dataset's levels).
pub use ipmc_fit::level::LevelData;

/// Every humidity reading of one session in time order: what the polymer's water content
/// followed (hydration lag).
#[derive(Clone, Debug, Default)]
pub struct RhHistory {
    pub t_s: Vec<f64>,
    pub rh_pct: Vec<f64>,
}

/// The input of a diagnosis.
#[derive(Clone, Debug, Default)]
pub struct Dataset {
    pub levels: Vec<LevelData>,
    pub histories: Vec<RhHistory>,
    /// Per session, the bursts a time series was estimated from (empty for a frequency
    /// response): each line's noise and the current's spectrum between the lines
    /// (`BetweenLines`, where mains and its harmonics show).
    pub bursts: Vec<Vec<ipmc_fit::multisine::Burst>>,
    /// The humidity sensor read at references (follow-ups of the `reference` protocol): its
    /// offset and gain, which the sensor-error candidate shares with the levels.
    pub references: Vec<ipmc_recording::HumidityReference>,
    /// The protocols of the follow-ups among the recordings (a follow-up is not asked for twice).
    pub followups: Vec<ipmc_recording::Protocol>,
}

impl Dataset {
    /// Groups every recording into levels (the recording crate's grouping) and keeps each
    /// session's humidity history. Points with a zero gain carry no phase and are dropped.
    pub fn from_recordings(recs: &[FrequencyResponse]) -> Self {
        Self::felt(recs, &HumidityPath::NONE)
    }

    /// The levels at the strip's humidity: the readings through the calibration's humidity
    /// `path` (its levels' RH and the RH histories), so a diagnosis looks for what the
    /// calibration does not already account for.
    pub fn felt(recs: &[FrequencyResponse], path: &HumidityPath) -> Self {
        let mut out = Dataset::default();
        for (session, rec) in recs.iter().enumerate() {
            let first = out.levels.len();
            let source = format!("recording {}", session + 1);
            let mut levels = rec.levels();
            ipmc_fit::recordings::levels_felt(rec, &mut levels, path, &source);
            let strip = ipmc_fit::recordings::strip_rh(rec, path, &source);
            for level in levels {
                let (mut l, _) = LevelData::from_level(&level, None);
                l.session = session;
                l.revisit_of = l.revisit_of.map(|i| first + i);
                out.levels.push(l);
            }
            let mut timed: Vec<(f64, f64)> = rec.points.iter().zip(&strip).filter_map(|(p, &rh)| p.time_s.map(|t| (t, rh))).collect();
            timed.sort_by(|a, b| a.0.total_cmp(&b.0));
            out.histories.push(RhHistory { t_s: timed.iter().map(|x| x.0).collect(), rh_pct: timed.iter().map(|x| x.1).collect() });
        }
        out
    }

    /// Reads the recording files into the levels a diagnosis fits, at the humidity `path` says
    /// the strip felt (the calibration's `[humidity]`).
    pub fn read(paths: &[std::path::PathBuf], path: &HumidityPath) -> anyhow::Result<Self> {
        let files = crate::input::strip_files::read(paths)?;
        Ok(Dataset::of(&files.iter().collect::<Vec<_>>(), path))
    }

    /// The dataset of `files` (sessions in the order given; references beside them).
    pub fn of(files: &[&crate::input::strip_files::StripFile], path: &HumidityPath) -> Self {
        use crate::input::strip_files::Content;
        let mut recs = Vec::new();
        let mut bursts = Vec::new();
        let mut references = Vec::new();
        for f in files {
            match &f.content {
                Content::Response(r) => {
                    recs.push(r.response.clone());
                    bursts.push(r.bursts.clone().unwrap_or_default());
                }
                Content::Reference(r) => references.push(r.clone()),
            }
        }
        let followups = files.iter().filter_map(|f| f.followup.as_ref().map(|u| u.protocol)).collect();
        Dataset { bursts, references, followups, ..Dataset::felt(&recs, path) }
    }

    pub fn has_times(&self) -> bool {
        self.levels.iter().all(|l| l.time_s.is_some())
    }

    /// Spread of the levels' temperatures [K], 0 when not recorded.
    pub fn temperature_span(&self) -> f64 {
        let t: Vec<f64> = self.levels.iter().filter_map(|l| l.temp_c).collect();
        if t.len() < self.levels.len() || t.is_empty() {
            return 0.0;
        }
        t.iter().cloned().fold(f64::NEG_INFINITY, f64::max) - t.iter().cloned().fold(f64::INFINITY, f64::min)
    }
}
