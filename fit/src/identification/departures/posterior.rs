//! What the model says at a humidity: the strip's departure from the law and the posterior sd
//! of ln θₖ, the mixture of the posteriors over the departure's lengths (mean Σwⱼμⱼ, variance
//! Σwⱼ(vⱼ + μⱼ²) − mean²), or the REML point's where a parameter has no departure. The written
//! law stays the REML point's; the table carries the mixture's mean less that law.
//!
//! Between two levels, a length under half their spacing leaves open not only how far the
//! strip departs between them but whether it departs again at all: it may go straight from one
//! level's value to the other's, as a table of calibration points is read. Levels that all sit
//! at setpoints cannot tell the two accounts apart (the likelihood of their values is the same),
//! so each takes half of that length's weight: its own posterior, and the straight line between
//! its posteriors at the two levels ((1 − w)²vₐ + w²v_b, their correlation left out). The spread
//! between the two stays in the variance. Lengths the levels do see interpolate already and
//! keep their whole weight.

use super::lengths::Component;
use super::model::StripModel;
use super::problem::{basis, ln_base};
use crate::gaussian_process::{cross_covariances, posterior_var};
use nalgebra::DVector;

/// The prior's share of the straight account between two levels, for each departure length
/// they cannot see (this file's doc): levels at the setpoints alone cannot tell
/// it from the length's own account, so neither is preferred.
const STRAIGHT_SHARE: f64 = 0.5;

impl StripModel {
    /// The humidities the levels were placed at, ascending, each once.
    pub fn positions(&self) -> Vec<f64> {
        let mut x: Vec<f64> = self.obs.iter().map(|o| o.1).collect();
        x.sort_by(f64::total_cmp);
        x.dedup();
        x
    }

    /// The posterior of the departure's length of parameter k: (length [%RH], weight) over
    /// the grid it is averaged on, negligible lengths left out; empty without a departure.
    pub fn length_posterior(&self, k: usize) -> Vec<(f64, f64)> {
        self.mixture[k].iter().map(|c| (c.length_pct, c.weight)).collect()
    }

    /// The smooth law of parameter k (order of
    /// [`DEPARTING`](ipmc_core::calibration::departures::DEPARTING)) at `x`, in ln.
    pub fn law_ln(&self, k: usize, x: f64) -> f64 {
        ln_base(&self.base, k, x)
            + self.degree[k]
                .map_or(0.0, |q| basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * self.beta[self.col[k] + j]).sum())
    }

    /// The covariances of the departure of parameter k at `x` (a humidity known exactly) with
    /// every observation (each at a humidity known up to its variance).
    fn k_star(&self, k: usize, x: f64) -> DVector<f64> {
        cross_covariances(&self.obs, self.has_departures[k], k, x, self.hyper.amplitude[k], self.hyper.length_pct[k])
    }

    /// The 5 %, 50 % and 95 % points of the departure length's posterior of parameter k [%RH]
    /// (the grid's lengths); None without a departure.
    pub fn length_quantiles(&self, k: usize) -> Option<[f64; 3]> {
        let c = &self.mixture[k];
        let at = |q: f64| {
            let mut sum = 0.0;
            c.iter().find(|c| {
                sum += c.weight;
                sum >= q
            })
        };
        let [a, b, d] = [0.05, 0.5, 0.95].map(|q| at(q).or(c.last()).map(|c| c.length_pct));
        Some([a?, b?, d?])
    }

    /// The strip's departure from the (REML point's) law of parameter k at `x`, in ln: the
    /// posterior mean of ln θₖ averaged over the departure's lengths, less that law.
    pub fn departure(&self, k: usize, x: f64) -> f64 {
        if self.mixture[k].is_empty() {
            return self.point_departure(k, x);
        }
        self.mixture_moments(k, x).map_or(f64::NAN, |(mean, _)| mean - self.law_ln(k, x))
    }

    /// The posterior standard deviation of ln θₖ at `x` (departure and law), averaged over the
    /// departure's lengths.
    pub fn posterior_sd(&self, k: usize, x: f64) -> f64 {
        if self.mixture[k].is_empty() {
            return self.point_sd(k, x);
        }
        self.mixture_moments(k, x).map_or(f64::NAN, |(_, var)| var.max(0.0).sqrt())
    }

    /// The departure's posterior mean at the REML point of its hyperparameters alone.
    pub fn point_departure(&self, k: usize, x: f64) -> f64 {
        self.k_star(k, x).dot(&self.alpha)
    }

    /// The posterior sd of ln θₖ at `x` at the REML point of the hyperparameters alone.
    pub fn point_sd(&self, k: usize, x: f64) -> f64 {
        let Some(q) = self.degree[k] else { return f64::NAN };
        let ks = self.k_star(k, x);
        let prior = if self.has_departures[k] { self.hyper.amplitude[k].powi(2) } else { 0.0 };
        posterior_var(&self.chol, &self.h, &self.hch_inv, &ks, prior, basis(x, self.center, self.half, q), self.col[k]).max(0.0).sqrt()
    }

    /// Mean and variance of ln θₖ at `x` over the lengths' mixture. Between two levels, each
    /// length too short for them to see (under half their spacing) stands for two accounts of
    /// the strip there that they cannot tell apart, half its weight each: departing again
    /// between them (the length's own posterior, back toward the law), or going straight from
    /// one level's value to the other's (module doc, "Between two levels").
    fn mixture_moments(&self, k: usize, x: f64) -> Option<(f64, f64)> {
        self.moments(k, x, STRAIGHT_SHARE)
    }

    /// [`Self::mixture_moments`] with the straight account's share of each unseen length
    /// `straight` (0: the lengths' own posteriors alone; 1: the straight line alone).
    pub(super) fn moments(&self, k: usize, x: f64, straight: f64) -> Option<(f64, f64)> {
        let between = self.between_levels(x);
        let (mut m1, mut m2) = (0.0, 0.0);
        for c in &self.mixture[k] {
            let (mean, var, law) = self.component_moments(k, c, x)?;
            let line = match between {
                Some((a, b, w)) if c.length_pct < 0.5 * (b - a) => {
                    let ((ma, va, la), (mb, vb, lb)) = (self.component_moments(k, c, a)?, self.component_moments(k, c, b)?);
                    Some((law + (1.0 - w) * (ma - la) + w * (mb - lb), (1.0 - w).powi(2) * va + w * w * vb))
                }
                _ => None,
            };
            match line {
                Some((ms, vs)) => {
                    let (own, other) = ((1.0 - straight) * c.weight, straight * c.weight);
                    m1 += own * mean + other * ms;
                    m2 += own * (var + mean * mean) + other * (vs + ms * ms);
                }
                None => {
                    m1 += c.weight * mean;
                    m2 += c.weight * (var + mean * mean);
                }
            }
        }
        Some((m1, m2 - m1 * m1))
    }

    /// The levels' humidities on either side of `x` and how far along from the lower one `x`
    /// lies; None at a level or beyond the outermost.
    fn between_levels(&self, x: f64) -> Option<(f64, f64, f64)> {
        let pos = self.positions();
        let i = pos.iter().position(|&p| p >= x)?;
        if i == 0 || (pos[i] - x).abs() < 1e-9 {
            return None;
        }
        let (a, b) = (pos[i - 1], pos[i]);
        Some((a, b, (x - a) / (b - a)))
    }

    /// Mean and variance of ln θₖ at `x` under one length's posterior, and its law there.
    fn component_moments(&self, k: usize, c: &Component, x: f64) -> Option<(f64, f64, f64)> {
        let q = self.degree[k]?;
        let ks = cross_covariances(&self.obs, true, k, x, c.amplitude, c.length_pct);
        let law = ln_base(&self.base, k, x)
            + basis(x, self.center, self.half, q).enumerate().map(|(j, b)| b * c.beta[self.col[k] + j]).sum::<f64>();
        let var = posterior_var(&c.chol, &self.h, &c.hch_inv, &ks, c.amplitude.powi(2), basis(x, self.center, self.half, q), self.col[k]);
        Some((law + ks.dot(&c.alpha), var.max(0.0), law))
    }
}
