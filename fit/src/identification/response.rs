//! Residuals of a measured frequency response against the core's exact model.
//!
//! A point is one (frequency, channel) pair: the tip response W(L)/U or the current I/U, measured
//! as gain and phase. The residual is the complex logarithm of measured / model, split into its
//! log-gain and phase parts and each divided by that point's σ: log gain because gains span
//! decades (a relative error is what the measurement has), and the phase of the ratio because it
//! needs no unwrapping.

// The measured points, here for whoever fits them.
pub use crate::measure::point::{Channel, Point, Sigma};
use crate::numeric::lsq::{Bound, Param};
use ipmc_core::model::exact::{jw, responses};
use ipmc_core::{C, ParamName, Params};

/// The name of the tip channel's gain when [`ResponseProblem::with_tip_gain`] fits it.
pub const TIP_GAIN: &str = "tip_gain";

/// How a point's misfit becomes a residual.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Misfit {
    /// ln(measured/model), split into log gain and phase: symmetric in over- and
    /// under-estimating the gain and blind to phase wrapping, so the landscape far from the
    /// optimum has no false walls. Biased where the noise is comparable to the signal.
    LogRatio,
    /// measured/model − 1: exactly the noise over the signal, Gaussian however weak the signal
    /// (the log of a noise-dominated gain is not), so it is what a fit weighted by each point's
    /// noise must use near the optimum.
    Relative,
    /// measured − model, in the channel's unit (σ too): weak points weigh little whatever
    /// their noise, which makes it the safe first fit of a channel whose noise is not known yet
    /// and may swamp its low-gain points (the current at low frequency).
    Difference,
}

impl Misfit {
    pub fn of(self, measured: C<f64>, model: C<f64>) -> C<f64> {
        match self {
            Misfit::LogRatio => log_ratio(measured, model),
            Misfit::Relative => measured / model - 1.0,
            Misfit::Difference => measured - model,
        }
    }
}

/// ln(measured / model): real part the log-gain error, imaginary part the phase error in (−π, π].
pub fn log_ratio(measured: C<f64>, model: C<f64>) -> C<f64> {
    (measured / model).ln()
}

/// Writes two weighted residuals per point (real part: gain, imaginary part: phase) given the
/// model's value at each point.
pub fn weighted_residuals(points: &[Point], sigmas: &[Sigma], misfit: Misfit, model: &[C<f64>], out: &mut [f64]) {
    for (((pt, s), m), r) in points.iter().zip(sigmas).zip(model).zip(out.chunks_exact_mut(2)) {
        r.copy_from_slice(&s.weigh(misfit.of(pt.value, *m)));
    }
}

/// Fitting some of the model's parameters (by their `--set` names) with the rest held at `base`.
#[derive(Clone, Debug)]
pub struct ResponseProblem<'a> {
    pub base: Params<f64>,
    pub fitted: Vec<ParamName>,
    pub points: &'a [Point],
    pub sigmas: &'a [Sigma],
    pub misfit: Misfit,
    /// Whether the tip channel's gain is fitted too: one more value after the fitted
    /// parameters, multiplying the model's tip response (the instrument's scale factor).
    pub tip_gain_free: bool,
    /// Points by frequency: where both channels were measured at one frequency the model
    /// evaluates them together ([`responses`]), which costs little more than one of them.
    by_freq: Vec<(f64, [Option<usize>; 2])>,
}

/// Groups point indices by frequency, tip first.
fn group_by_frequency(points: &[Point]) -> Vec<(f64, [Option<usize>; 2])> {
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by(|&a, &b| points[a].freq_hz.total_cmp(&points[b].freq_hz));
    let mut groups: Vec<(f64, [Option<usize>; 2])> = Vec::new();
    for i in order {
        let slot = match points[i].channel {
            Channel::Tip => 0,
            Channel::Current => 1,
        };
        match groups.last_mut() {
            Some((f, g)) if *f == points[i].freq_hz && g[slot].is_none() => g[slot] = Some(i),
            _ => {
                let mut g = [None, None];
                g[slot] = Some(i);
                groups.push((points[i].freq_hz, g));
            }
        }
    }
    groups
}

/// The model at every point.
pub fn model_values(p: &Params<f64>, points: &[Point]) -> Vec<C<f64>> {
    let mut out = vec![C::new(0.0, 0.0); points.len()];
    fill_model_values(p, points, &group_by_frequency(points), &mut out);
    out
}

fn fill_model_values(p: &Params<f64>, points: &[Point], by_freq: &[(f64, [Option<usize>; 2])], out: &mut [C<f64>]) {
    for &(f, [tip, current]) in by_freq {
        match (tip, current) {
            (Some(t), Some(c)) => (out[t], out[c]) = responses(p, jw(f)),
            (Some(i), None) | (None, Some(i)) => out[i] = points[i].channel.model(p, f),
            (None, None) => {}
        }
    }
}

impl<'a> ResponseProblem<'a> {
    pub fn new(base: Params<f64>, fitted: &[ParamName], points: &'a [Point], sigmas: &'a [Sigma], misfit: Misfit) -> Self {
        assert_eq!(points.len(), sigmas.len(), "one σ per point");
        ResponseProblem { base, fitted: fitted.to_vec(), points, sigmas, misfit, tip_gain_free: false, by_freq: group_by_frequency(points) }
    }

    /// The same problem with the tip channel's gain fitted as well (named `tip_gain`, started
    /// at 1).
    pub fn with_tip_gain(mut self) -> Self {
        self.tip_gain_free = true;
        self
    }

    /// Every model parameter is positive and the identified ones span decades across humidity
    /// (d by two): all are fitted in their logarithm.
    pub fn lsq_params(&self) -> Vec<Param> {
        let mut v: Vec<Param> = self.fitted.iter().map(|p| Param::new(p.as_str(), Bound::Positive)).collect();
        if self.tip_gain_free {
            v.push(Param::new(TIP_GAIN, Bound::Positive));
        }
        v
    }

    pub fn n_residuals(&self) -> usize {
        2 * self.points.len()
    }

    /// `base` with the fitted parameters replaced by `values`.
    pub fn params(&self, values: &[f64]) -> Params<f64> {
        let mut p = self.base;
        for (&name, &v) in self.fitted.iter().zip(values) {
            p.set(name, v);
        }
        p
    }

    /// The start values at `base`.
    pub fn start(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.fitted.iter().map(|&p| self.base.get(p)).collect();
        if self.tip_gain_free {
            v.push(1.0);
        }
        v
    }

    /// The model at every point for `values`, the tip's scaled by the fitted tip gain.
    fn model(&self, values: &[f64]) -> Vec<C<f64>> {
        let mut model = vec![C::new(0.0, 0.0); self.points.len()];
        fill_model_values(&self.params(values), self.points, &self.by_freq, &mut model);
        if self.tip_gain_free {
            let g = values[self.fitted.len()];
            for (m, p) in model.iter_mut().zip(self.points) {
                if p.channel == Channel::Tip {
                    *m *= g;
                }
            }
        }
        model
    }

    pub fn residuals(&self, values: &[f64], out: &mut [f64]) {
        weighted_residuals(self.points, self.sigmas, self.misfit, &self.model(values), out);
    }

    /// χ² at `values` (for ranking starts).
    pub fn chi2(&self, values: &[f64]) -> f64 {
        let mut r = vec![0.0; self.n_residuals()];
        self.residuals(values, &mut r);
        r.iter().map(|x| x * x).sum()
    }

    /// Unweighted measured/model − 1 per point at `values` (what noise estimation looks at),
    /// with the model's gain there.
    pub fn relative_errors(&self, values: &[f64]) -> (Vec<C<f64>>, Vec<f64>) {
        let model = self.model(values);
        self.points.iter().zip(&model).map(|(pt, &g)| (Misfit::Relative.of(pt.value, g), g.norm())).unzip()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ipmc_core::Calibration;

    #[test]
    fn residuals_vanish_on_the_model_and_ignore_phase_wrapping() {
        let p: Params<f64> = Calibration::default_preset().params_at(55.0);
        let points: Vec<Point> = [20.0, 90.0, 300.0]
            .iter()
            .flat_map(|&f| {
                Channel::BOTH.map(|ch| {
                    let v = ch.model(&p, f);
                    // a measured phase unwrapped by a full turn is the same measurement
                    Point::new(f, ch, v.norm(), v.arg().to_degrees() - 360.0)
                })
            })
            .collect();
        let sigmas = vec![Sigma::UNIT; points.len()];
        let problem = ResponseProblem::new(p, &[ParamName::Y, ParamName::D], &points, &sigmas, Misfit::LogRatio);
        let mut r = vec![1.0; problem.n_residuals()];
        problem.residuals(&problem.start(), &mut r);
        assert!(r.iter().all(|x| x.abs() < 1e-9), "{r:?}");
        // 1 % more Y moves the tip residuals
        problem.residuals(&[p.y * 1.01, p.d], &mut r);
        assert!(r.iter().any(|x| x.abs() > 1e-3));
    }
}
