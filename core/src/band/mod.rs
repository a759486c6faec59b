//! The band an estimate is good in (the file's `[band]` table), and the linear-phase filter at
//! the end of the chain that keeps it.
//!
//! A calibration is measured over a band (its frequency responses, its time series' lines).
//! Below it the inverse's gain rises as 1/ω² down to its regularizing high-pass, and lifts the
//! current's white noise there by orders of magnitude over what it adds in band (on realistic
//! recordings the raw estimate was 33–51× the true base motion's rms); above it the model is
//! unchecked. So the chain keeps only this band of its estimate, and every figure of error is
//! taken in it.
//!
//! Any causal minimum-phase high-pass steep enough to matter turns the phase at the band's lower
//! edge by tens of degrees (Bode's gain–phase integral), which the design's 1 % flatness in band
//! cannot take. A linear-phase filter can: its only cost in band is a pure delay, which the chain
//! already reports. The transitions lie outside the band ([`transition_hz`] each side), so the
//! band itself keeps the design's accuracy.
//!
//! Both transitions of the band-pass are narrow (6 Hz for the default band), which at 2 kHz takes
//! a 793-tap FIR. The band ends at 150 Hz, so the band-pass runs at a quarter of the rate behind
//! two half-bands (polyphase, down and back up), with a quarter of the taps: a tenth of the cost,
//! the same response in band. Below the band the inverse lifts the current's noise as 1/f⁴, so
//! the lower edge wants a transition narrower still ([`lower_transition_hz`], 8–10 Hz): after
//! the band-pass, at its rate, its output delayed less a low-pass of it run at an eighth of that
//! rate (the complement, `lower_edge`). Every filter in it is linear-phase, so the whole is too.
//!
//! The coefficients are designed once (windowed sinc, Kaiser window) in f64 and narrowed to the
//! working precision, so the firmware and its host replica run the same bits.
//! - `kaiser`: the window, the length a transition needs, the windowed ideal filters;
//! - `spec`: the `[band]` table, and the plan of stages and taps a rate keeps it with;
//! - `design`: the coefficients in f64, and the response every figure through the band uses;
//! - `history`: the samples a filter still needs, the sums over them, and a delay;
//! - `half_band`: a half-band stage as it runs, down and up;
//! - `lower_edge`: the lower edge's complement as it runs;
//! - `minimum_phase`: the low-latency option's edges ([`Shape::LowLatency`]);
//! - `running`: the filter at the working precision, its coefficients and its lines apart (a second
//!   signal through the same filter holds lines alone).

mod design;
mod half_band;
mod history;
mod kaiser;
mod lower_edge;
pub mod minimum_phase;
mod running;
mod spec;

pub use design::{BandCoefficients, BandDesign, MAX_EDGE_HALF, MAX_HALF, MAX_HALF_BAND_PAIRS};
pub use running::{BandLimit, BandLines, BandTaps, LineSizes, LinesMut, RunLines};
pub use spec::{
    ATTENUATION_DB, Band, BandLimitError, HALF_BAND_ATTENUATION_DB, MAX_EDGE_DELAY, MAX_EDGE_STAGES, MAX_EDGE_TAPS, MAX_TAPS, Plan, Shape,
    check, lower_transition_hz, lowest_low_hz, transition_hz,
};

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 2000.0;

    /// The band's bounds on the tests' grids: its largest ripple in 10–150 Hz, and its largest
    /// gain at the transitions' far ends. Both are what a single-rate FIR of 793 taps at 2 kHz
    /// reaches on the same grids (its gain there below 4 Hz and above 156 Hz).
    const MAX_IN_BAND_RIPPLE: f64 = 0.00906;
    const MAX_GAIN_PAST_TRANSITIONS: f64 = 0.01024;

    fn ripple(d: &BandDesign) -> f64 {
        (0..=1400).map(|i| (d.response(10.0 + 0.1 * i as f64).re - 1.0).abs()).fold(0.0, f64::max)
    }

    /// Largest gain beyond the transitions' far ends: below the lower edge's (8 Hz for the default
    /// band), above the upper's (156 Hz), or `beyond` Hz further out.
    fn stop(d: &BandDesign, beyond: f64) -> f64 {
        let below = (0..=((800.0 - 100.0 * beyond) as usize)).map(|i| d.response(0.01 * i as f64).re.abs());
        let above = (0..=((8440.0 - 10.0 * beyond) as usize)).map(|i| d.response(156.0 + beyond + 0.1 * i as f64).re.abs());
        below.chain(above).fold(0.0, f64::max)
    }

    /// What the filter lets through ends where its transitions do: the lower one starts at 0.8
    /// of the edge, the upper one ends 0.6 of the lower edge above the upper edge; a tenth of a
    /// transition's width either way is the Kaiser design's own slack at its stop band's level.
    #[test]
    fn support_ends_where_the_transitions_do() {
        let band = Band::DEFAULT;
        let (lo, hi) = BandDesign::design(&band, FS).unwrap().support_hz(&band);
        let (lower, upper) = (lower_transition_hz(&band), transition_hz(&band));
        assert!((lo - (band.low_hz - lower)).abs() <= 0.1 * lower, "{lo}");
        assert!((hi - (band.high_hz + upper)).abs() <= 0.1 * upper, "{hi}");
    }

    #[test]
    fn coefficients_stored_in_f32_run_as_those_in_f64() {
        // The firmware's band is baked narrowed to f32 (build.rs); its f32 filter must be the one
        // the design itself makes, bit for bit.
        for shape in [Shape::LinearPhase, Shape::LowLatency] {
            let d = BandDesign::design(&Band { shape, ..Band::DEFAULT }, FS).unwrap();
            let wide = d.coefficients();
            let narrow = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<std::vec::Vec<_>>();
            let (half, edge_half) = (narrow(wide.half), narrow(wide.edge_half));
            let pairs: std::vec::Vec<_> = wide.pairs.iter().map(|p| narrow(p)).collect();
            let edge_pairs: std::vec::Vec<_> = wide.edge_pairs.iter().map(|p| narrow(p)).collect();
            let stored = BandCoefficients {
                plan: wide.plan,
                half: &half,
                pairs: core::array::from_fn(|s| &pairs[s][..]),
                edge_half: &edge_half,
                edge_pairs: core::array::from_fn(|s| &edge_pairs[s][..]),
                sections: wide.sections.map(|s| {
                    let (b, a, beta, alpha) = s.parts();
                    let n = |v: &[f64]| -> [f32; 3] { core::array::from_fn(|i| v.get(i).map_or(0.0, |&x| x as f32)) };
                    crate::Sos::from_parts(n(&b), n(&a), n(&beta), [alpha[0] as f32, alpha[1] as f32])
                }),
            };
            let (mut from_wide, mut from_stored) = (BandLimit::<f32>::identity(), BandLimit::<f32>::identity());
            from_wide.load(&wide);
            from_stored.load(&stored);
            let mut x: std::vec::Vec<f32> = (0..2000).map(|i| libm::sinf(0.37 * i as f32) + if i % 97 == 0 { 1.0 } else { 0.0 }).collect();
            let mut y = x.clone();
            from_wide.process_block(&mut x);
            from_stored.process_block(&mut y);
            assert!(x.iter().zip(&y).all(|(a, b)| a.to_bits() == b.to_bits()), "{shape:?}");
        }
    }

    #[test]
    fn flat_in_band_and_deep_outside() {
        let d = BandDesign::design(&Band::DEFAULT, FS).unwrap();
        let p = d.plan();
        assert_eq!((p.stages, p.half_band_taps, p.taps), (2, [15, 27, 0, 0], 205), "{p:?}");
        assert_eq!((p.edge_stages, p.edge_half_band_taps, p.edge_taps), (3, [11, 15, 15], 79), "{p:?}");
        let r = ripple(&d);
        assert!(r <= MAX_IN_BAND_RIPPLE, "ripple in band {r}");
        // At the transitions' far ends (8 and 156 Hz), as deep as a single-rate FIR of 793 taps
        // is at its own (4 and 156 Hz); a hertz beyond, the design's depth.
        let (s, deep) = (stop(&d, 0.0), stop(&d, 1.0));
        assert!(s <= MAX_GAIN_PAST_TRANSITIONS, "outside the transitions {s}");
        assert!(deep <= 10f64.powf(-42.0 / 20.0), "a hertz beyond the transitions {deep}");
        // The lower transition is the edge's, 8–10 Hz: half the band already at 9 Hz.
        let mid = d.response(9.0).re;
        assert!((0.3..0.7).contains(&mid), "9 Hz passes {mid}");
    }

    /// A tone's output, fitted as a·sin + b·cos at `f_out` over the settled part, and the rms of
    /// what is left (aliases, images, the filter's own rounding).
    fn through(f: &mut BandLimit<f64>, f_in: f64, f_out: f64) -> (crate::C<f64>, f64) {
        f.reset();
        // The band's impulse response is 2.2 s long: scored from 3 s.
        let n = 20_000;
        let tone = |fr: f64, i: usize| (2.0 * core::f64::consts::PI * fr * i as f64 / FS).sin();
        let mut x: std::vec::Vec<f64> = (0..n).map(|i| tone(f_in, i)).collect();
        for c in x.chunks_mut(37) {
            f.process_block(c);
        }
        let settled = 6000..n;
        let (mut ss, mut sc, mut cc, mut ys, mut yc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        let w = 2.0 * core::f64::consts::PI * f_out / FS;
        for i in settled.clone() {
            let (s, c) = ((w * i as f64).sin(), (w * i as f64).cos());
            (ss, sc, cc, ys, yc) = (ss + s * s, sc + s * c, cc + c * c, ys + x[i] * s, yc + x[i] * c);
        }
        let det = ss * cc - sc * sc;
        let (a, b) = ((ys * cc - yc * sc) / det, (yc * ss - ys * sc) / det);
        let rest = settled.clone().map(|i| (x[i] - a * (w * i as f64).sin() - b * (w * i as f64).cos()).powi(2)).sum::<f64>();
        (crate::C::new(a, b), (rest / settled.len() as f64).sqrt())
    }

    #[test]
    fn runs_its_response_with_its_delay_and_nothing_else() {
        let d = BandDesign::design(&Band::DEFAULT, FS).unwrap();
        let mut f = BandLimit::<f64>::from_design(&d);
        // In band: the design's response and delay, and what the rate changes add 70 dB down.
        for f_hz in [10.0, 10.6, 23.0, 40.0, 97.0, 150.0] {
            let (ab, rest) = through(&mut f, f_hz, f_hz);
            let w = 2.0 * core::f64::consts::PI * f_hz / FS * d.delay_samples() as f64;
            // sin(ωi − φ) = cos φ·sin ωi − sin φ·cos ωi.
            let want = crate::C::new(w.cos(), -w.sin()) * d.response(f_hz);
            assert!((ab - want).norm() < 1e-4, "{f_hz} Hz: {ab:?} against {want:?}");
            assert!(rest < 1e-3 * core::f64::consts::FRAC_1_SQRT_2, "{f_hz} Hz: {rest} beside the tone");
        }
        // Outside: the rms of everything that comes out, aliases included, 42 dB down.
        let floor = 10f64.powf(-42.0 / 20.0) * core::f64::consts::FRAC_1_SQRT_2;
        // The lower edge's complement cancels its low-pass's path against the delayed band-pass
        // only where the two are aligned to the sample: 5–7 Hz tells.
        for f_hz in [0.5, 2.0, 3.9, 5.0, 6.2, 7.0, 157.0, 200.0, 344.0, 400.0, 500.0, 656.0, 844.0, 900.0, 1000.0 - 23.0] {
            let (ab, rest) = through(&mut f, f_hz, f_hz);
            let out = (ab.norm_sqr() / 2.0 + rest * rest).sqrt();
            assert!(out < floor, "{f_hz} Hz comes out at {out}");
        }
    }

    #[test]
    fn the_low_latency_band_is_quick_and_runs_its_response() {
        let band = Band::DEFAULT.with_shape(Shape::LowLatency);
        let d = BandDesign::design(&band, FS).unwrap();
        assert_eq!(d.delay_samples(), 0);
        // Group delay −dφ/dω from the response's phase, every 1 Hz from 20 to 150 Hz.
        let phase = |f: f64| {
            let h = d.response(f);
            h.im.atan2(h.re)
        };
        let worst = (20..=150)
            .map(|f| {
                let f = f as f64;
                let mut dp = phase(f + 0.01) - phase(f - 0.01);
                if dp > core::f64::consts::PI {
                    dp -= 2.0 * core::f64::consts::PI;
                }
                -dp / (2.0 * core::f64::consts::PI * 0.02)
            })
            .fold(0.0, f64::max);
        assert!(worst <= minimum_phase::MAX_GROUP_DELAY_S && worst > 0.001, "group delay up to {worst} s");
        assert!(d.response(2.0).norm() < 0.01 && d.response(300.0).norm() < 0.1, "{} {}", d.response(2.0).norm(), d.response(300.0).norm());
        let mut f = BandLimit::<f64>::from_design(&d);
        for f_hz in [3.0, 12.0, 40.0, 150.0, 400.0] {
            let (ab, rest) = through(&mut f, f_hz, f_hz);
            // sin(ωi + φ)·|H| = |H| cos φ·sin ωi + |H| sin φ·cos ωi.
            let h = d.response(f_hz);
            assert!((ab - crate::C::new(h.re, h.im)).norm() < 1e-6, "{f_hz} Hz: {ab:?} against {h:?}");
            assert!(rest < 1e-6, "{f_hz} Hz: {rest} beside the tone");
        }
    }

    #[test]
    fn refuses_bands_it_cannot_keep() {
        assert!(matches!(BandDesign::design(&Band { low_hz: 2.0, ..Band::DEFAULT }, FS), Err(BandLimitError::TooLow { .. })));
        assert!(matches!(BandDesign::design(&Band { high_hz: 996.0, ..Band::DEFAULT }, FS), Err(BandLimitError::AboveNyquist)));
        // Above 194 Hz the band-pass runs at 1 kHz, where a lower edge needs twice the taps.
        assert!(matches!(
            check(&Band { low_hz: 12.0, high_hz: 200.0, ..Band::DEFAULT }, FS),
            Err(BandLimitError::TooLow { needed: 341, .. })
        ));
        assert!(check(&Band { low_hz: 35.0, high_hz: 390.0, ..Band::DEFAULT }, FS).is_ok());
        let low = lowest_low_hz(FS, 150.0);
        assert!(
            check(&Band { low_hz: low, ..Band::DEFAULT }, FS).is_ok() && check(&Band { low_hz: low - 0.1, ..Band::DEFAULT }, FS).is_err()
        );
    }

    #[test]
    fn the_edge_holds_what_any_band_the_taps_allow_needs() {
        // The complement's line is sized by the taps' limits, which set the lowest edge: at no
        // rate does a band both filters keep need a longer one (its guard in `check` never bites).
        let mut most = 0;
        for fs in [500.0, 1000.0, 2000.0, 4000.0, 8000.0] {
            for high in (20..=2000).step_by(10) {
                for low in (30..400).map(|l| l as f64 / 10.0).take_while(|&l| l < high as f64) {
                    if let Ok(p) = check(&Band { low_hz: low, high_hz: high as f64, ..Band::DEFAULT }, fs) {
                        most = most.max(p.edge_path_delay());
                    }
                }
            }
        }
        assert!((406..=MAX_EDGE_DELAY).contains(&most), "{most}");
    }

    /// The lines hold what any plan leaves in them, however the input is cut: every band from
    /// none of the half-bands to four, with one to three of the lower edge's, through blocks of 1 to
    /// 100 samples, comes out bit for bit as through blocks of 32.
    #[test]
    fn any_plan_runs_the_same_through_any_blocks() {
        let bands = [
            (10.0, 150.0, 2000.0),
            (10.0, 40.0, 2000.0),
            (12.0, 60.0, 2000.0),
            (25.0, 200.0, 2000.0),
            (30.6, 390.0, 2000.0),
            (35.0, 390.0, 1000.0),
            (10.0, 150.0, 8000.0),
        ];
        let mut stages_seen = [false; 5];
        for (low_hz, high_hz, fs) in bands {
            let d = BandDesign::design(&Band { low_hz, high_hz, ..Band::DEFAULT }, fs)
                .unwrap_or_else(|e| panic!("{low_hz}–{high_hz} Hz at {fs}: {e}"));
            stages_seen[d.plan().stages] = true;
            let x: std::vec::Vec<f32> = (0..6000).map(|i| libm::sinf(0.013 * i as f32) + if i % 89 == 0 { 1.0 } else { 0.0 }).collect();
            let mut by_32 = x.clone();
            let mut f = BandLimit::<f32>::from_design(&d);
            by_32.chunks_mut(32).for_each(|c| f.process_block(c));
            for cut in [1, 3, 5, 17, 31, 33, 48, 64, 100] {
                let mut y = x.clone();
                f.reset();
                y.chunks_mut(cut).for_each(|c| f.process_block(c));
                assert!(y.iter().zip(&by_32).all(|(a, b)| a.to_bits() == b.to_bits()), "{low_hz}–{high_hz} Hz at {fs}: blocks of {cut}");
            }
        }
        assert!(stages_seen.iter().all(|&s| s), "{stages_seen:?}");
    }

    #[test]
    fn keeps_a_band_at_any_rate_it_allows() {
        for fs in [1000.0, 2000.0, 4000.0, 8000.0, 10_000.0] {
            let d = BandDesign::design(&Band::DEFAULT, fs).unwrap();
            let r = (0..=140).map(|i| (d.response(10.0 + i as f64).re - 1.0).abs()).fold(0.0, f64::max);
            assert!(r <= 0.01, "{fs} Hz: {:?} ripple {r}", d.plan());
        }
    }

    /// Lines sized to the default band's plan at 2 kHz (the device's, baked by build.rs) run its
    /// filter bit for bit as the general ones do, in less room; lines too small for a plan are
    /// refused before they run.
    #[test]
    fn lines_sized_to_one_plan_run_it_as_the_general_ones() {
        type OfPlan = BandLines<f32, 2, 301, 111, 406>;
        let d = BandDesign::design(&Band::DEFAULT, FS).unwrap();
        assert_eq!(LineSizes::of(&d.plan()), OfPlan::SIZES);
        let f = BandLimit::<f32>::from_design(&d);
        let x: std::vec::Vec<f32> = (0..6000).map(|i| libm::sinf(0.029 * i as f32) + if i % 71 == 0 { 0.5 } else { 0.0 }).collect();
        let (mut general, mut sized) = (x.clone(), x);
        let mut lines = BandLines::<f32>::at_rest(f.taps());
        general.chunks_mut(32).for_each(|c| lines.process_block(f.taps(), c));
        let mut lines = OfPlan::at_rest(f.taps());
        sized.chunks_mut(32).for_each(|c| lines.process_block(f.taps(), c));
        assert!(general.iter().zip(&sized).all(|(a, b)| a.to_bits() == b.to_bits()));
        let saved = core::mem::size_of::<BandLines<f32>>() - core::mem::size_of::<OfPlan>();
        assert!(saved >= 1600, "{saved} B");
        let too_small = std::panic::catch_unwind(|| BandLines::<f32, 2, 301, 111, 405>::at_rest(f.taps()));
        assert!(too_small.is_err());
    }
}
