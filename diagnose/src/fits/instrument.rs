//! The instrument's channels (the tip's and the current's gains against the base's, and their
//! shared delay) fitted with every level's base parameters, their tolerances as priors, and the
//! prior a candidate's joint fit carries them with.

use super::base::{BASE, LevelSigmas, Mask, RefitError, Result, Theta, base_bound, fitted_base, inside, level_params, write_residuals};
use ipmc_core::model::extension::Extension;
use ipmc_core::{C, Calibration};
use ipmc_fit::block_qr::Reach;
use ipmc_fit::level::LevelData;
use ipmc_fit::lsq::{self, Blocks, Bound, Param, Tolerance};

/// What the acquisition puts on the model's responses: the tip and current channels' gains
/// relative to the base channel's (ln), and a delay the tip and current channels share against
/// the base. The ratios a level is recorded as are tip/base and current/base, so the base
/// channel's own gain enters both as its inverse.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Channels {
    pub ln_tip: f64,
    pub ln_current: f64,
    pub delay_s: f64,
}

impl Channels {
    /// ln of what the channels multiply the model's (tip, current) ratios by at `freq_hz`.
    pub fn ln_factors(&self, freq_hz: f64) -> (C<f64>, C<f64>) {
        let phase = -2.0 * core::f64::consts::PI * freq_hz * self.delay_s;
        (C::new(self.ln_tip, phase), C::new(self.ln_current, phase))
    }

    /// The level as the model with these channels removed would have recorded it.
    pub fn corrected(&self, level: &LevelData) -> LevelData {
        let mut out = level.clone();
        for (i, &f) in level.freqs.iter().enumerate() {
            let (t, c) = self.ln_factors(f);
            out.tip[i] = level.tip[i].map(|v| v * (-t).exp());
            out.current[i] = level.current[i].map(|v| v * (-c).exp());
        }
        out
    }
}

/// The instrument's nuisance parameters fitted with the plain model (see [`fit_instrument`]):
/// ln of the tip, base and current channels' gains and the shared delay [µs], each with its
/// standard error (NaN where its tolerance is zero and it was held).
#[derive(Clone, Debug)]
pub struct InstrumentFit {
    pub channels: Channels,
    pub names: [&'static str; 4],
    pub values: [f64; 4],
    pub std_errors: [f64; 4],
    /// Σ ((value − prior mean)/prior σ)² at the optimum.
    pub prior_chi2: f64,
    /// The levels' base parameters refitted with the channels.
    pub theta: Vec<Theta>,
}

/// The channels' parameters (ln gains, delay in µs) with their prior means and 1σ from the
/// calibration's `[instrument]` table.
fn instrument_priors(prior: &ipmc_core::calibration::instrument::Instrument) -> [(&'static str, f64, f64); 4] {
    [
        ("ln tip gain", prior.tip_gain.ln(), prior.tip_gain_tolerance_pct / 100.0),
        ("ln base gain", 0.0, prior.base_gain_tolerance_pct / 100.0),
        ("ln current gain", 0.0, prior.current_gain_tolerance_pct / 100.0),
        ("acquisition delay µs", 0.0, prior.acquisition_delay_us),
    ]
}

/// The instrument as a candidate's joint fit carries it: the identifiable channels (the tip's
/// and the current's gains relative to the base's, ln, and the shared delay [µs]), where the
/// plain model put them (`at`, already taken out of the data the candidate is fitted on), their
/// prior mean and the Cholesky factor of their prior covariance (the base channel's tolerance
/// is shared by both ratios, so they are correlated). The fit moves them by δ from `at` with
/// the prior's residuals L⁻¹(at + δ − mean) as rows, as the plain model paid.
#[derive(Clone, Debug)]
pub struct ChannelPrior {
    /// Which of (tip, current, delay) are free (a zero tolerance holds one).
    pub free: Vec<usize>,
    pub at: [f64; 3],
    pub mean: [f64; 3],
    /// Lower-triangular factor of the free channels' prior covariance.
    pub chol: Vec<Vec<f64>>,
    /// Σ of the plain model's prior residuals² (at δ = 0).
    pub plain_chi2: f64,
}

impl ChannelPrior {
    pub fn new(fit: &InstrumentFit, prior: &ipmc_core::calibration::instrument::Instrument) -> Option<Self> {
        let (st, sb, sc, sd) = (
            prior.tip_gain_tolerance_pct / 100.0,
            prior.base_gain_tolerance_pct / 100.0,
            prior.current_gain_tolerance_pct / 100.0,
            prior.acquisition_delay_us,
        );
        let cov = [[st * st + sb * sb, sb * sb, 0.0], [sb * sb, sc * sc + sb * sb, 0.0], [0.0, 0.0, sd * sd]];
        let free: Vec<usize> = (0..3).filter(|&i| cov[i][i] > 0.0).collect();
        if free.is_empty() {
            return None;
        }
        let n = free.len();
        let mut chol = vec![vec![0.0; n]; n];
        for i in 0..n {
            for j in 0..=i {
                let mut v = cov[free[i]][free[j]];
                for m in 0..j {
                    v -= chol[i][m] * chol[j][m];
                }
                chol[i][j] = if i == j { v.max(1e-300).sqrt() } else { v / chol[j][j] };
            }
        }
        let ch = fit.channels;
        let mut out = ChannelPrior {
            free,
            at: [ch.ln_tip, ch.ln_current, ch.delay_s * 1e6],
            mean: [prior.tip_gain.ln(), 0.0, 0.0],
            chol,
            plain_chi2: 0.0,
        };
        out.plain_chi2 = out.chi2_at(&vec![0.0; n]);
        Some(out)
    }

    /// The prior's residuals at the free channels moved by `delta`.
    pub fn residuals(&self, delta: &[f64], out: &mut [f64]) {
        for i in 0..self.free.len() {
            let mut v = self.at[self.free[i]] + delta[i] - self.mean[self.free[i]];
            for m in 0..i {
                v -= self.chol[i][m] * out[m];
            }
            out[i] = v / self.chol[i][i];
        }
    }

    /// The channels' move δ as channels.
    pub fn channels(&self, delta: &[f64]) -> Channels {
        let mut v = [0.0; 3];
        for (&i, &d) in self.free.iter().zip(delta) {
            v[i] = d;
        }
        Channels { ln_tip: v[0], ln_current: v[1], delay_s: v[2] * 1e-6 }
    }

    /// The move that puts every free channel at its prior mean.
    pub fn move_to_mean(&self) -> Vec<f64> {
        self.free.iter().map(|&c| self.mean[c] - self.at[c]).collect()
    }

    /// Whether a free channel moved by `channels` (from where the plain model put them) sits at
    /// the edge of its reach, within 1 % of the reach's width.
    pub fn at_reach(&self, channels: &Channels) -> bool {
        let moved = [channels.ln_tip, channels.ln_current, channels.delay_s * 1e6];
        self.params().iter().zip(&self.free).any(|(p, &c)| match p.bound {
            Bound::Between(lo, hi) => (moved[c] - lo).min(hi - moved[c]) < 0.01 * (hi - lo),
            _ => false,
        })
    }

    /// The prior's Σ residuals² with the free channels moved by `delta`.
    pub fn chi2_at(&self, delta: &[f64]) -> f64 {
        let mut r = vec![0.0; self.free.len()];
        self.residuals(delta, &mut r);
        r.iter().map(|v| v * v).sum()
    }

    /// The free channels as parameters of a fit, moving within [`PRIOR_REACH`] of the prior.
    pub fn params(&self) -> Vec<Param> {
        let names = ["ln tip/base gain move", "ln current/base gain move", "acquisition delay move µs"];
        (0..self.free.len())
            .map(|i| {
                let c = self.free[i];
                let sd = (0..=i).map(|m| self.chol[i][m].powi(2)).sum::<f64>().sqrt();
                let centre = self.mean[c] - self.at[c];
                Param::new(names[c], Bound::Between(centre - PRIOR_REACH * sd, centre + PRIOR_REACH * sd))
            })
            .collect()
    }
}

/// Residuals written by [`write_residuals`] for the model times the channels `ch`.
pub fn shift_residuals(level: &LevelData, sig: &LevelSigmas, mask: &Mask, ch: &Channels, out: &mut [f64]) {
    let mut k = 0;
    for (i, &f) in level.freqs.iter().enumerate() {
        let (t, c) = ch.ln_factors(f);
        for (value, ln, s, on) in [(level.tip[i], t, sig.tip[i], mask.tip[i]), (level.current[i], c, sig.current[i], mask.current[i])] {
            if let (Some(_), true) = (value, on) {
                out[k] -= ln.re / s.ln_gain;
                out[k + 1] -= ln.im / s.phase;
                k += 2;
            }
        }
    }
}

fn channels_of(v: &[f64; 4]) -> Channels {
    Channels { ln_tip: v[0] - v[1], ln_current: v[2] - v[1], delay_s: v[3] * 1e-6 }
}

/// How far the fit lets a channel go from its prior mean, in prior σ: beyond it the prior
/// gives odds below 3·10⁻⁴, and a departure that large is the strip's or a candidate's
/// (a larger delay is `current_timing` / `tip_timing`), not a tolerance.
const PRIOR_REACH: f64 = 4.0;

/// Every level's base parameters fitted jointly with the instrument's channels, whose
/// tolerances enter as Gaussian priors (MAP: the prior's residuals are rows of the fit). A
/// channel whose tolerance is zero is held at its mean. Without this, a tip sensor reading
/// 0.5 % high (inside any laser's datasheet) is a departure no per-level refit absorbs: the tip
/// follows the base below resonance, so a gain shows at every frequency, and a candidate that
/// bends the response (a tip mass) is handed it.
pub fn fit_instrument(
    calib: &Calibration,
    levels: &[LevelData],
    sig: &[LevelSigmas],
    masks: &[Mask],
    prior: &ipmc_core::calibration::instrument::Instrument,
    base: &[Theta],
) -> Result<InstrumentFit> {
    let priors = instrument_priors(prior);
    let held: Vec<usize> = (0..4).filter(|&i| !(priors[i].2 > 0.0)).collect();
    let free_globals: Vec<usize> = (0..4).filter(|i| !held.contains(i)).collect();
    let mut at_prior = [0.0; 4];
    for (i, p) in priors.iter().enumerate() {
        at_prior[i] = p.1;
    }
    if free_globals.is_empty() {
        return Ok(InstrumentFit {
            channels: channels_of(&at_prior),
            names: priors.map(|p| p.0),
            values: at_prior,
            std_errors: [f64::NAN; 4],
            prior_chi2: 0.0,
            theta: base.to_vec(),
        });
    }
    let k = free_globals.len();
    let free: Vec<Vec<usize>> = levels.iter().map(fitted_base).collect();
    let mut params: Vec<Param> = free_globals
        .iter()
        .map(|&i| {
            let (name, mu, s) = priors[i];
            Param::new(name, Bound::Between(mu - PRIOR_REACH * s, mu + PRIOR_REACH * s))
        })
        .collect();
    let mut start: Vec<f64> = free_globals.iter().map(|&i| priors[i].1).collect();
    for (l, level) in levels.iter().enumerate() {
        for &b in &free[l] {
            let bound = base_bound(calib, level, b);
            params.push(Param::new(format!("{} at level {l}", BASE[b].as_str()), bound));
            start.push(inside(bound, base[l][b]));
        }
    }
    let globals = |v: &[f64]| -> [f64; 4] {
        let mut g = at_prior;
        for (j, &i) in free_globals.iter().enumerate() {
            g[i] = v[j];
        }
        g
    };
    let mut counts: Vec<usize> = masks.iter().map(|m| m.count()).collect();
    counts.push(k);
    let first: Vec<usize> = free.iter().scan(k, |at, f| Some(std::mem::replace(at, *at + f.len()))).collect();
    let level_theta = |v: &[f64], l: usize| -> Theta {
        let mut th = base[l];
        for (&b, &x) in free[l].iter().zip(&v[first[l]..]) {
            th[b] = x;
        }
        th
    };
    let mut reach = vec![Reach::Global; k];
    for (l, f) in free.iter().enumerate() {
        reach.extend(std::iter::repeat_n(Reach::Block(l), f.len()));
    }
    let blocks = Blocks { sizes: &counts, reach: &reach };
    let n = levels.len();
    let residuals = |v: &[f64], l: usize, out: &mut [f64]| {
        if l == n {
            for (j, &i) in free_globals.iter().enumerate() {
                out[j] = (v[j] - priors[i].1) / priors[i].2;
            }
            return;
        }
        let p = level_params(calib, &levels[l], &level_theta(v, l));
        let corrected = channels_of(&globals(v)).corrected(&levels[l]);
        write_residuals(&corrected, &sig[l], &masks[l], &p, &Extension::default(), out);
    };
    let fit = lsq::fit_blocks(Tolerance::REPORT, &params, &[start], blocks, residuals).map_err(RefitError::Joint)?;
    let values = globals(&fit.estimates);
    let mut std_errors = [f64::NAN; 4];
    for (j, &i) in free_globals.iter().enumerate() {
        std_errors[i] = fit.std_errors[j];
    }
    let prior_chi2 = free_globals.iter().map(|&i| ((values[i] - priors[i].1) / priors[i].2).powi(2)).sum();
    Ok(InstrumentFit {
        channels: channels_of(&values),
        names: priors.map(|p| p.0),
        values,
        std_errors,
        prior_chi2,
        theta: (0..n).map(|l| level_theta(&fit.estimates, l)).collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fits::base::calibration_theta;
    use crate::fits::test_levels::{even_sigmas, recorded};
    use ipmc_core::Params;
    use ipmc_core::model::exact::jw;

    /// Levels made by the model, recorded through a tip channel reading 0.6 % high: the
    /// instrument's fit finds the gain (the tip follows the base below resonance, which no
    /// level's Y, Cs, Ca or d can bend), leaves the delay alone, and the recordings corrected
    /// by it are the model's again.
    #[test]
    fn the_instrument_fit_finds_a_tip_channel_off_its_scale() {
        let calib = Calibration::default_preset();
        let freqs: Vec<f64> = (0..30).map(|i| 10.0 * 15f64.powf(i as f64 / 29.0)).collect();
        let levels: Vec<LevelData> = [40.0, 55.0, 70.0]
            .iter()
            .map(|&rh| {
                let p: Params<f64> = calib.params_at(rh);
                let r = freqs.iter().map(|&f| (ipmc_core::tip_response(&p, jw(f)) * 1.006, ipmc_core::current_response(&p, jw(f))));
                recorded(rh, &freqs, r.collect())
            })
            .collect();
        let sig = even_sigmas(&levels, 0.001, 0.001);
        let masks: Vec<Mask> = levels.iter().map(Mask::all).collect();
        let start: Vec<Theta> = levels.iter().map(|l| calibration_theta(&calib, l.rh_pct)).collect();
        // Where a per-level refit would start the fit: near the truth, not on it.
        let start: Vec<Theta> = start.iter().map(|t| t.map(|v| v + 0.01)).collect();
        let fit =
            fit_instrument(&calib, &levels, &sig, &masks, &ipmc_core::calibration::instrument::Instrument::DATASHEET, &start).unwrap();
        let ch = fit.channels;
        assert!((ch.ln_tip - 1.006f64.ln()).abs() < 3e-4, "{ch:?}");
        // The current's gain is not asserted: it trades off against each level's d and Ca (it is
        // degenerate with κe and d), and only its prior holds it.
        assert!(ch.delay_s.abs() < 2e-6, "{ch:?}");
        let corrected = ch.corrected(&levels[1]);
        let p: Params<f64> = calib.params_at(55.0);
        let r = (corrected.tip[0].unwrap() / ipmc_core::tip_response(&p, jw(freqs[0]))).norm();
        assert!((r - 1.0).abs() < 5e-4, "{r}");
    }
}
