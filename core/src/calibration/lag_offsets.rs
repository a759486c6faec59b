//! The sensor's offset a check found, given each hydration lag the strip may have: the
//! `[humidity.lag_offsets]` table, written by `ipmc recalibrate`, read by the strip's own
//! hygrometer.
//!
//! A check measures the strip's humidity; the sensor's offset is that less the reading as the
//! strip followed it, through the strip's hydration lag. Where the calibration's path gives no
//! lag, the hygrometer weighs the lags of a grid ([`HYDRATION_LAGS_S`]), and while the air moves
//! the reading through each differs: one check's mean cannot tell them apart, so it does not
//! give one offset but one per lag. Each is the check's strip humidity less the reading through that lag,
//! with its 1σ given that lag (the check's own, without the spread over lags). The hygrometer
//! corrects each lag's path by its own offset, with its own 1σ as the prior on the sensor's bias
//! there: the spread over the lags is then counted once, in the mixture over them, not again in
//! a prior that holds it too. The check's course tells the lags apart as far as it can (the
//! strip's humidity over parts of the check against the reading through each lag): `weight`,
//! each lag's probability, the hygrometer's prior over them. `[humidity] offset_pct` and
//! `uncertainty_pct` stay the offset over the lags as one (their mean and, spread included, 1σ,
//! by those weights), for a path read without the lags.

/// The strip's hydration lags the fusion weighs when the calibration's humidity path has none
/// [s]. The strip's humidity follows the air through its water uptake, the reading follows it
/// at once: while the air moves, reading − strip is the sensor's bias plus the rate times the
/// lag, and a bias learned without the lag follows the last ramp. A thin strip in air takes
/// tens of seconds to minutes (a Nafion film's uptake; lags of 1–2.5 min measured on the lab's bench); equal
/// weights on a doubling grid are a log-uniform prior over 7–230 s, and the fits' agreement with
/// each decides among them as far as the data can. These are the strip's lags behind the air;
/// the reading trails the air by its sensor's own lag already, so the path is lagged by the
/// difference (`BlockHygrometer::new`).
pub const HYDRATION_LAGS_S: [f64; 5] = [10.0, 20.0, 40.0, 80.0, 160.0];
/// How many lags the grid has.
pub const LAGS: usize = HYDRATION_LAGS_S.len();

/// The `[humidity.lag_offsets]` table: per lag of [`HYDRATION_LAGS_S`], in its order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(try_from = "file::LagOffsetsFile", into = "file::LagOffsetsFile"))]
pub struct LagOffsets {
    /// The sensor's offset given the lag, less the table's `offset_pct` [%RH].
    pub offset_pct: [f64; LAGS],
    /// Its 1σ given the lag [%RH].
    pub sd_pct: [f64; LAGS],
    /// The lag's probability from the checks (summing to 1; without a course, equal).
    pub weight: [f64; LAGS],
    /// Per two neighbouring lags of the grid, how much of the spread between their paths is one
    /// lag between them rather than either (without a course, 0). The course reads the lag on a
    /// finer grid and shares each fine lag between its two neighbours, so that their mixture
    /// trails as the fine lag does: a lag the course decides between two grid lags is their
    /// mixture for sure, and the spread of their two paths no uncertainty of it. Of the pair's
    /// spread p_k·p_{k+1}·(h_k − h_{k+1})², the part that is the mixture's own, relative to it:
    /// Σ p·x(1−x) over the fine lags between them (x their place from the one to the other) over
    /// w_k·w_{k+1}. 1 for a lag decided between the two; above 1 where the pair holds a small
    /// part of the probability, spread over it; the spread less these is then exactly the fine
    /// lags' own for a path linear in the lag.
    pub between: [f64; LAGS - 1],
}

/// The grid's prior: every lag alike.
pub const EQUAL_WEIGHTS: [f64; LAGS] = [1.0 / LAGS as f64; LAGS];
/// Without a course: no pair of lags known to hold one lag between them.
pub const NONE_BETWEEN: [f64; LAGS - 1] = [0.0; LAGS - 1];

impl LagOffsets {
    /// The lag `k` of the grid's offset beyond `offset_pct` and its 1σ.
    pub fn at(&self, k: usize) -> (f64, f64) {
        (self.offset_pct[k], self.sd_pct[k])
    }

    /// The weights checked: each finite and within 0–1, their sum 1 within rounding; each
    /// `between` finite and not negative.
    pub fn weights_valid(&self) -> bool {
        let unit = |w: &f64| w.is_finite() && (0.0..=1.0).contains(w);
        let share = |b: &f64| b.is_finite() && *b >= 0.0;
        self.weight.iter().all(unit) && (self.weight.iter().sum::<f64>() - 1.0).abs() < 1e-6 && self.between.iter().all(share)
    }
}

#[cfg(feature = "serde")]
mod file {
    extern crate std;
    use super::{EQUAL_WEIGHTS, HYDRATION_LAGS_S, LAGS, LagOffsets, NONE_BETWEEN};
    use std::string::String;
    use std::vec::Vec;

    /// The file's form: the lags it was found for (the grid's, or the table is refused: a
    /// calibration recalibrated for another grid is recalibrated again), the offsets, their 1σ.
    #[derive(serde::Serialize, serde::Deserialize)]
    #[serde(deny_unknown_fields)]
    pub struct LagOffsetsFile {
        lag_s: Vec<f64>,
        offset_pct: Vec<f64>,
        sd_pct: Vec<f64>,
        /// Absent in a file whose checks did not weigh the lags: equal.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        weight: Option<Vec<f64>>,
        /// Absent in a file whose checks did not read the lag finer than the grid: none.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        between: Option<Vec<f64>>,
    }

    impl TryFrom<LagOffsetsFile> for LagOffsets {
        type Error = String;
        fn try_from(f: LagOffsetsFile) -> Result<Self, String> {
            if f.lag_s != HYDRATION_LAGS_S {
                return Err(std::format!(
                    "humidity.lag_offsets.lag_s: the hygrometer weighs the lags {HYDRATION_LAGS_S:?} s; this table is for others \
                     (recalibrate from the checks again)"
                ));
            }
            let (Ok(offset), Ok(sd)) = (<[f64; LAGS]>::try_from(f.offset_pct), <[f64; LAGS]>::try_from(f.sd_pct)) else {
                return Err(std::format!("humidity.lag_offsets: offset_pct and sd_pct have one number per lag ({LAGS})"));
            };
            let weight = match f.weight {
                None => EQUAL_WEIGHTS,
                Some(w) => {
                    <[f64; LAGS]>::try_from(w).map_err(|_| std::format!("humidity.lag_offsets.weight: one number per lag ({LAGS})"))?
                }
            };
            let between = match f.between {
                None => NONE_BETWEEN,
                Some(b) => <[f64; LAGS - 1]>::try_from(b)
                    .map_err(|_| std::format!("humidity.lag_offsets.between: one number per two neighbouring lags ({})", LAGS - 1))?,
            };
            let t = LagOffsets { offset_pct: offset, sd_pct: sd, weight, between };
            if !t.weights_valid() {
                return Err(std::format!(
                    "humidity.lag_offsets.weight = {weight:?}, between = {between:?}: weights within 0–1 summing to 1, between none negative"
                ));
            }
            // Their ranges are the path's to check, with its offset's (`HumidityPath::validate`).
            Ok(t)
        }
    }

    impl From<LagOffsets> for LagOffsetsFile {
        fn from(t: LagOffsets) -> Self {
            LagOffsetsFile {
                lag_s: HYDRATION_LAGS_S.to_vec(),
                offset_pct: t.offset_pct.to_vec(),
                sd_pct: t.sd_pct.to_vec(),
                weight: Some(t.weight.to_vec()),
                between: Some(t.between.to_vec()),
            }
        }
    }
}
