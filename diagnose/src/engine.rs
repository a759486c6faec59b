//! The diagnosis in order: refit the plain model per level and estimate the noise, locate the
//! mismatch, score every candidate of the library, decide, and gather what the report and its
//! figures show.
//!
//! **Held out.** Each level in turn is left out, and the score is its χ² per residual (1 = at
//! the noise), each candidate against its own null (its kind's scorer, [`crate::scorers`]):
//! - a model candidate's global parameters are fitted on the other levels (their base
//!   parameters held where the joint fit put them; one Gauss–Newton step from the joint
//!   optimum, [`crate::scorers`]' model scorer) and the held-out level's own four base
//!   parameters are refitted with them, as the plain model's are: the level's drift from the
//!   calibration is not the candidate's business, and judging the candidate by humidity laws
//!   would bury a small effect under the scatter of the parameters between levels;
//! - mains interference: the level refitted without its line points, which are scored by the
//!   interference power the other levels show;
//! - hydration lag, humidity sensor error and temperature: the level's base parameters from
//!   the calibration at the remapped humidity (τ, or offset and gain, from the other levels) or
//!   with the level's temperature acting (its coefficients from the other levels), plus the
//!   other levels' mean drift from it, against the calibration at the humidity as read plus
//!   that drift.
//!
//! With no effect named, the numbers and figures are the per-level refit's.
//!
//! **Information criterion.** BIC differences ΔBIC = Δχ² − Δk·ln N on the data (model and mains
//! candidates) or on the per-level parameters (candidates acting through humidity).
//!
//! **Decision.** [`crate::verdict::decide`].

use crate::candidates::LIBRARY;
use crate::evidence::context::{Baseline, Ctx};
use crate::evidence::held_out::{REFIT_NULL_IS, per_level_scores};
use crate::evidence::laws;
use crate::evidence::locate;
use crate::fits;
use crate::input::data::Dataset;
use crate::scorers;
use crate::verdict::decide::decide;
use crate::verdict::types::{Diagnosis, LevelModels, LevelSummary};
use anyhow::Result;
use ipmc_core::Calibration;
use ipmc_core::model::extension::Extension;

/// Runs the whole diagnosis, the candidates scored over the machine's cores. `progress` is told
/// each step's name.
pub fn diagnose(calib: &Calibration, data: &Dataset, progress: &(dyn Fn(&str) + Sync)) -> Result<Diagnosis> {
    diagnose_over(calib, data, progress, std::thread::available_parallelism().map_or(1, |n| n.get()))
}

/// [`diagnose`] with the candidates scored on `workers` threads (one: one after another). The
/// result does not depend on `workers`.
pub fn diagnose_over(calib: &Calibration, data: &Dataset, progress: &(dyn Fn(&str) + Sync), workers: usize) -> Result<Diagnosis> {
    let levels = &data.levels;
    anyhow::ensure!(levels.len() >= 3, "a diagnosis needs at least three humidity levels, the recordings have {}", levels.len());
    for l in levels {
        anyhow::ensure!(l.freqs.len() >= 5, "the level at {:.1} %RH has only {} frequencies (at least 5 needed)", l.rh_pct, l.freqs.len());
    }
    progress("the instrument's channels");
    let instrument = {
        let (plain, _, _) = Ctx::new(calib, data)?;
        fits::fit_instrument(calib, levels, &plain.sig, &plain.all, &calib.instrument, &plain.base.theta)?
    };
    // Every candidate is scored on the recordings with the channels the plain model found taken
    // out: what the instrument's tolerances explain is not missing physics. The channels are
    // profiled at the plain model's optimum, not refitted with each candidate, which can only
    // take evidence from a candidate (the channels took first what they could), never give it.
    let corrected = Dataset {
        levels: levels.iter().map(|l| instrument.channels.corrected(l)).collect(),
        histories: data.histories.clone(),
        bursts: data.bursts.clone(),
        references: data.references.clone(),
        followups: data.followups.clone(),
    };
    let data = &corrected;
    let levels = &data.levels;
    progress("per-level refit and noise");
    let (mut ctx, noise, cal_theta) = Ctx::new(calib, data)?;
    ctx.channel_prior = fits::ChannelPrior::new(&instrument, &calib.instrument);
    let n_levels = levels.len();
    let counts: Vec<f64> = ctx.all.iter().map(|m| m.count() as f64).collect();
    let simulation: Vec<f64> = (0..n_levels)
        .map(|l| {
            let p = fits::level_params(calib, &levels[l], &cal_theta[l]);
            fits::chi2(&levels[l], &ctx.sig[l], &ctx.all[l], &p, &Extension::default()) / counts[l]
        })
        .collect();
    let (law_pred_0, law_k_0) = laws::fitted(&ctx.read, &ctx.base.theta, &ctx.base.se);
    let base = Baseline {
        heldout_before: crate::evidence::held_out::weighted_mean(&per_level_scores(&ctx.law_heldout(&ctx.plain())), &counts),
        n_data: crate::evidence::context::total_residuals(&ctx.all) as f64,
        chi2_0: ctx.base.chi2.iter().sum(),
        law0: (laws::nll(&law_pred_0, &ctx.base.theta, &ctx.base.se, &ctx.read_gradient), law_k_0),
        n_theta: ctx.base.se.iter().flatten().filter(|s| !s.is_nan()).count() as f64,
        counts,
    };
    let trace = std::env::var_os("IPMC_TRACE").is_some();
    if trace {
        eprintln!("base fits and noise done");
    }
    progress("locating the mismatch");
    let located = locate::locate(ctx.calib, data, &ctx.sig, &ctx.base, &cal_theta, &simulation)?;

    let scored = score_library(&ctx, &base, progress, trace, workers)?;
    let mut scores = Vec::with_capacity(scored.len());
    let mut fitted_of = Vec::with_capacity(scored.len());
    let mut heldout_of = Vec::with_capacity(scored.len());
    let mut at_reach = Vec::with_capacity(scored.len());
    for s in scored {
        at_reach.push(s.channels_at_reach);
        scores.push(s.score);
        fitted_of.push(s.fitted);
        heldout_of.push(s.held);
    }
    // The plain model's channels take what they can of a concealed effect first. Where one sits
    // at the edge of its reach, each candidate that explains part of the mismatch (ΔBIC > 0)
    // and left the channel there may be explaining less than it could: it is fitted again from
    // the channels' prior mean and keeps the better fit (`fits::ChannelStart::PriorMean`).
    let plain_at_reach = ctx.channel_prior.as_ref().is_some_and(|p| p.at_reach(&fits::Channels::default()));
    if plain_at_reach {
        ctx.channel_start = fits::ChannelStart::PriorMean;
        let again = |i: usize| at_reach[i] == Some(true) && scores[i].delta_bic > 0.0;
        let again: Vec<usize> = (0..LIBRARY.len()).filter(|&i| again(i)).collect();
        for (i, cand) in again.into_iter().map(|i| (i, &LIBRARY[i])) {
            progress(cand.name());
            let s = scorers::score(&ctx, cand, &base)?;
            if s.score.delta_chi2 > scores[i].delta_chi2 {
                if trace {
                    eprintln!(
                        "{}: from the channels' prior mean Δχ² {:.1} → {:.1}",
                        cand.label(),
                        scores[i].delta_chi2,
                        s.score.delta_chi2
                    );
                }
                scores[i] = s.score;
                fitted_of[i] = s.fitted;
                heldout_of[i] = s.held;
            }
        }
        ctx.channel_start = fits::ChannelStart::Plain;
    }
    let decision = decide(&ctx, LIBRARY, &mut scores, &fitted_of, &base, &located.summary);

    // The held-out models the numbers score: the winner's and its null's, or the per-level refit
    // when no effect is named (the model candidates' null: the humidity laws' would report the
    // scatter of the parameters between levels, tens of σ, beside "no missing physics").
    let (before_models, before_is, after_models, after_is) = match decision.winner.and_then(|w| heldout_of[w].take()) {
        Some(h) => (h.null, h.null_is, Some(h.candidate), Some(h.candidate_is)),
        None => (ctx.refit_null(), REFIT_NULL_IS.to_string(), None, None),
    };
    let before_per_level = per_level_scores(&before_models);
    let after_per_level = after_models.as_deref().map_or_else(|| before_per_level.clone(), per_level_scores);
    let summaries = (0..n_levels)
        .map(|l| LevelSummary {
            rh_pct: levels[l].rh_pct,
            time_s: levels[l].time_s,
            temp_c: levels[l].temp_c,
            revisit_of: levels[l].revisit_of,
            simulation_chi2_per_residual: simulation[l],
            refit_chi2_per_residual: ctx.base.chi2[l] / base.counts[l],
            heldout_before: before_per_level[l],
            heldout_after: after_per_level[l],
        })
        .collect();
    let mut after_models = after_models.map(Vec::into_iter);
    let models = before_models
        .into_iter()
        .enumerate()
        .map(|(l, before)| LevelModels {
            simulation: fits::level_params(calib, &levels[l], &cal_theta[l]),
            refit: fits::level_params(calib, &levels[l], &ctx.base.theta[l]),
            before,
            after: after_models.as_mut().and_then(Iterator::next),
        })
        .collect();
    let mut ranked = scores;
    // Held-out scores of different candidates have different nulls: rank by the evidence.
    ranked.sort_by(|a, b| b.passes.cmp(&a.passes).then(b.applicable.cmp(&a.applicable)).then(b.delta_bic.total_cmp(&a.delta_bic)));
    let humidity_path = decision
        .verdict
        .effect()
        .filter(|e| matches!(e, crate::Effect::HydrationLag | crate::Effect::HumiditySensorError))
        .map(|_| crate::humidity::path::fit(&ctx, decision.overdispersion));
    let humidity_reach = crate::humidity::reach::reach(&ctx, base.law0, base.n_theta);
    let layout = layout(data);
    let within_none = crate::verdict::followup_request::within_none(
        &decision.probabilities,
        &decision.within_none,
        &ranked,
        &humidity_reach,
        layout.temp_c.is_some(),
        !layout.taken.is_empty() && matches!(decision.verdict, crate::Verdict::None | crate::Verdict::Unexplained),
    );
    let open = crate::verdict::followup_request::open_hypotheses(&decision.probabilities, &within_none);
    let request = crate::verdict::followup_request::request(decision.verdict, &open, &humidity_reach, &layout);
    Ok(Diagnosis {
        instrument: crate::verdict::types::InstrumentReport::of(&instrument, &calib.instrument),
        channels: instrument.channels,
        verdict: decision.verdict,
        probabilities: decision.probabilities,
        within_none,
        tempering: decision.tempering,
        set: decision.set,
        separation: decision.separation,
        indistinguishable: decision.alternatives,
        overdispersion: decision.overdispersion,
        family: decision.family,
        form: decision.form,
        explanation: decision.explanation,
        params: decision.params,
        heldout_before: decision.heldout.0,
        heldout_after: decision.heldout.1,
        located,
        candidates: ranked,
        levels: summaries,
        noise,
        models,
        heldout_before_is: before_is,
        heldout_after_is: after_is,
        humidity_path,
        humidity_reach,
        request,
    })
}

/// Every candidate of the library scored, returned in the library's order. The candidates are
/// independent given the context, so they are shared out over `workers` threads, each taking
/// the next candidate not yet taken, the hydration lag first (a diagnosis of a strip with its follow-ups fits twice the
/// levels, and one candidate's joint fit can take seconds).
fn score_library(
    ctx: &Ctx,
    base: &Baseline,
    progress: &(dyn Fn(&str) + Sync),
    trace: bool,
    workers: usize,
) -> Result<Vec<scorers::Scored>> {
    use std::sync::Mutex;
    use std::sync::atomic::{AtomicUsize, Ordering};
    let next = AtomicUsize::new(0);
    // The hydration lag first: its nested fits over the lag are the longest scoring, and begun
    // last they would leave the other workers idle at the end.
    let after_the_lag = |c: &crate::candidates::Candidate| {
        !matches!(c.kind, crate::candidates::Kind::Humidity(crate::candidates::HumidityMap::HydrationLag))
    };
    let mut order: Vec<usize> = (0..LIBRARY.len()).collect();
    order.sort_by_key(|&i| after_the_lag(&LIBRARY[i]));
    let results: Mutex<Vec<Option<Result<scorers::Scored>>>> = Mutex::new((0..LIBRARY.len()).map(|_| None).collect());
    let workers = workers.clamp(1, LIBRARY.len());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                while let Some(&i) = order.get(next.fetch_add(1, Ordering::Relaxed)) {
                    let cand = &LIBRARY[i];
                    progress(cand.name());
                    let t0 = std::time::Instant::now();
                    let s = scorers::score(ctx, cand, base);
                    if trace && let Ok(s) = &s {
                        let sc = &s.score;
                        eprintln!(
                            "{}: {:.2} s dBIC {:.1} heldout {:.3} null {:.3} z {:.1} {:?}",
                            cand.label(),
                            t0.elapsed().as_secs_f64(),
                            sc.delta_bic,
                            sc.heldout,
                            sc.heldout_null,
                            sc.heldout_z,
                            sc.params.iter().map(|p| p.value).collect::<Vec<_>>()
                        );
                    }
                    results.lock().unwrap_or_else(|e| e.into_inner())[i] = Some(s);
                }
            });
        }
    });
    results
        .into_inner()
        .unwrap_or_else(|e| e.into_inner())
        .into_iter()
        .map(|r| r.unwrap_or_else(|| Err(anyhow::anyhow!("a candidate was not scored"))))
        .collect()
}

/// The primary sessions' humidity range, band and room temperature, which a follow-up repeats.
fn layout(data: &Dataset) -> crate::verdict::followup_request::Layout {
    let levels = &data.levels;
    let fold = |v: &mut dyn Iterator<Item = f64>| v.fold([f64::INFINITY, f64::NEG_INFINITY], |[a, b], x| [a.min(x), b.max(x)]);
    let temps: Vec<f64> = levels.iter().filter_map(|l| l.temp_c).collect();
    let primary: Vec<f64> = levels.iter().filter(|l| l.session == 0).filter_map(|l| l.time_s).collect();
    let span_s = fold(&mut primary.iter().copied());
    let session_h = if primary.len() >= 2 && span_s[1] > span_s[0] {
        (span_s[1] - span_s[0]) / 3600.0
    } else {
        0.25 * levels.iter().filter(|l| l.session == 0).count() as f64
    };
    crate::verdict::followup_request::Layout {
        session_h,
        rh_range_pct: fold(&mut levels.iter().map(|l| l.rh_pct)),
        band_hz: fold(&mut levels.iter().flat_map(|l| l.freqs.iter().copied())),
        temp_c: (!temps.is_empty() && temps.len() == levels.len()).then(|| temps.iter().sum::<f64>() / temps.len() as f64),
        taken: data.followups.clone(),
    }
}
