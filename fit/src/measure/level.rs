//! One visit of one humidity level as every fit takes it: the measured responses per frequency
//! and what else the recording says of the level (when and at what temperature it was measured,
//! which session, the earlier visit it repeats, κe measured there).

use crate::measure::point::{Channel, Point};
use crate::numeric::estimate::Estimate;
use ipmc_core::C;
use ipmc_recording::{FrPoint, Response};

#[derive(Clone, Debug)]
pub struct LevelData {
    /// Which recording (session) the level comes from (0 for a single recording).
    pub session: usize,
    /// Mean humidity reading [%].
    pub rh_pct: f64,
    /// Mean temperature [°C], when recorded.
    pub temp_c: Option<f64>,
    /// Mean measurement time [s] from the session's start, when recorded.
    pub time_s: Option<f64>,
    /// First and last measurement time [s], when recorded.
    pub time_span: Option<(f64, f64)>,
    /// Index of the earlier visit of this humidity (among the session's levels, or wherever
    /// the caller gathers them).
    pub revisit_of: Option<usize>,
    /// Frequencies [Hz], ascending.
    pub freqs: Vec<f64>,
    /// Measured W(L)/U and I/U per frequency (None where the channel was not recorded or its
    /// gain is 0).
    pub tip: Vec<Option<C<f64>>>,
    pub current: Vec<Option<C<f64>>>,
    /// κe from a charging recording at this level; otherwise the base calibration's.
    pub kappa_e: Option<Estimate>,
}

fn usable(r: &Option<Response>) -> bool {
    r.as_ref().is_some_and(|r| r.gain > 0.0)
}

fn complex(r: &Option<Response>) -> Option<C<f64>> {
    r.as_ref().map(|r| C::from_polar(r.gain, r.phase_deg.to_radians()))
}

impl LevelData {
    /// One recorded level. A zero gain has no logarithm and no phase; such values are left out
    /// and their lines returned.
    pub fn from_level(level: &ipmc_recording::Level, kappa_e: Option<Estimate>) -> (LevelData, Vec<usize>) {
        let n = level.points.len() as f64;
        let mean = |f: &dyn Fn(&FrPoint) -> Option<f64>| -> Option<f64> {
            let v: Option<Vec<f64>> = level.points.iter().map(f).collect();
            v.map(|v| v.iter().sum::<f64>() / n)
        };
        let left_out: Vec<usize> = level
            .points
            .iter()
            .flat_map(|p| [p.tip, p.current].into_iter().filter(|r| r.is_some() && !usable(r)).map(move |_| p.line))
            .collect();
        let pts: Vec<&FrPoint> = level.points.iter().filter(|p| usable(&p.tip) || usable(&p.current)).collect();
        let data = LevelData {
            session: 0,
            rh_pct: level.rh_pct,
            temp_c: mean(&|p| p.temp_c),
            time_s: mean(&|p| p.time_s),
            time_span: level
                .points
                .iter()
                .map(|p| p.time_s)
                .collect::<Option<Vec<f64>>>()
                .map(|t| (t.iter().cloned().fold(f64::INFINITY, f64::min), t.iter().cloned().fold(f64::NEG_INFINITY, f64::max))),
            revisit_of: level.revisit_of,
            freqs: pts.iter().map(|p| p.freq_hz).collect(),
            tip: pts.iter().map(|p| if usable(&p.tip) { complex(&p.tip) } else { None }).collect(),
            current: pts.iter().map(|p| if usable(&p.current) { complex(&p.current) } else { None }).collect(),
            kappa_e,
        };
        (data, left_out)
    }

    /// The measured values as points, in frequency order, tip before current at each.
    pub fn points(&self) -> Vec<Point> {
        let mut out = Vec::with_capacity(2 * self.freqs.len());
        for (i, &freq_hz) in self.freqs.iter().enumerate() {
            for (channel, value) in [(Channel::Tip, self.tip[i]), (Channel::Current, self.current[i])] {
                if let Some(value) = value {
                    out.push(Point { freq_hz, channel, value });
                }
            }
        }
        out
    }
}
