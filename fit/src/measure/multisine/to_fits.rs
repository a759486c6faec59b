//! The bursts as the fits take them: each channel's noise model fitted to the lines' own σ, and
//! the bursts as a frequency-response recording.

use super::burst::{Burst, Line, Ratio};
use crate::measure::noise::{self, ChannelNoise};
use crate::measure::point::{Channel, Point};
use ipmc_core::C;
use ipmc_recording::{FrPoint, FrequencyResponse, Response};

/// Each channel's noise over all bursts as the fits model it (`noise::ChannelNoise`: σ² =
/// rel² + (floor² + rising floor²)/|H|², the same for ln gain and phase), fitted to the lines' own σ: what a fit
/// can weigh a time series' points with instead of estimating the noise from its residuals.
/// (tip, current); None for a channel not recorded or with fewer than three finite σ.
pub fn channel_noise(bursts: &[Burst]) -> (Option<ChannelNoise>, Option<ChannelNoise>) {
    let of = |channel: Channel, pick: &dyn Fn(&Line) -> Option<Ratio>| {
        let mut points = vec![];
        let mut errors = vec![];
        let mut gains = vec![];
        for l in bursts.iter().flat_map(|b| &b.lines) {
            let Some(r) = pick(l).filter(|r| r.sigma.is_finite() && r.value.norm() > 0.0) else { continue };
            points.push(Point { freq_hz: l.freq_hz, channel, value: r.value });
            // A complex error whose two parts each have the line's variance.
            errors.push(C::new(r.sigma, r.sigma));
            gains.push(r.value.norm());
        }
        noise::estimate(&points, &errors, &gains, channel, 0)
    };
    (of(Channel::Tip, &|l| l.tip), of(Channel::Current, &|l| Some(l.current)))
}

/// The bursts as a frequency-response recording: one point per line, at the burst's mean
/// humidity, temperature and time, so that every frequency-response reader takes them.
pub fn to_frequency_response(bursts: &[Burst], metadata: &ipmc_recording::Metadata) -> FrequencyResponse {
    let response = |r: &Ratio| Response { gain: r.value.norm(), phase_deg: r.value.arg().to_degrees() };
    let points = bursts
        .iter()
        .flat_map(|b| {
            b.lines.iter().map(move |l| FrPoint {
                line: 0,
                time_s: Some(b.time_s()),
                rh_pct: b.rh_pct,
                temp_c: b.temp_c,
                freq_hz: l.freq_hz,
                tip: l.tip.as_ref().map(response),
                current: Some(response(&l.current)),
            })
        })
        .collect();
    FrequencyResponse { metadata: metadata.clone(), points }
}
