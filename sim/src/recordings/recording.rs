//! What a simulation makes ([`Recording`]): a frequency response, a time series with the number
//! format its session asks for, or one charging recording per level; and the files it is
//! written as.

use anyhow::Result;
use ipmc_recording::{Charging, FrequencyResponse, NumberFormat, TimeSeries};
use std::path::{Path, PathBuf};

/// A simulated recording, ready to write.
pub enum Recording {
    FrequencyResponse(FrequencyResponse),
    TimeSeries(TimeSeries, NumberFormat),
    /// One charging recording per level.
    Charging(Vec<Charging>),
}

impl Recording {
    /// The file(s) to write for output path `out`: `out` itself, or for charging at several
    /// levels one file per level, `STEM-<RH>pct.csv` beside it.
    pub fn files(&self, out: &Path) -> Result<Vec<(PathBuf, String)>> {
        Ok(match self {
            Recording::FrequencyResponse(fr) => vec![(out.to_path_buf(), fr.to_csv()?)],
            Recording::TimeSeries(ts, format) => vec![(out.to_path_buf(), ts.to_csv(*format)?)],
            Recording::Charging(list) if list.len() == 1 => vec![(out.to_path_buf(), list[0].to_csv()?)],
            Recording::Charging(list) => {
                let stem = out.file_stem().map_or("charging".into(), |s| s.to_string_lossy().into_owned());
                let mut files = Vec::with_capacity(list.len());
                for (k, c) in list.iter().enumerate() {
                    // The level index keeps revisited levels apart.
                    let name = format!("{stem}-{k:02}-{}pct.csv", c.rh_pct.map_or("unknown".into(), |r| format!("{r:.0}")));
                    files.push((out.with_file_name(name), c.to_csv()?));
                }
                files
            }
        })
    }

    /// The recording's one file as text (a charging session at several levels has several).
    pub fn to_csv(&self) -> Result<String> {
        let mut files = self.files(Path::new("recording.csv"))?;
        anyhow::ensure!(files.len() == 1, "{} files, not one", files.len());
        Ok(files.remove(0).1)
    }

    /// One line saying what was made.
    pub fn summary(&self) -> String {
        match self {
            Recording::FrequencyResponse(fr) => {
                format!("{} frequency-response points at {} humidity levels", fr.points.len(), fr.levels().len())
            }
            Recording::TimeSeries(ts, _) => format!("{} samples in {} bursts at {} Hz", ts.len(), ts.bursts().len(), ts.fs_hz),
            Recording::Charging(list) => {
                format!("{} charging recording(s) of {} samples", list.len(), list.first().map_or(0, |c| c.t_s.len()))
            }
        }
    }
}
