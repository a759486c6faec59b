//! The firmware's start-up, as a state machine with no clock and no hardware of its own: when to
//! ask for the first filter design, at which humidity, and whether the start-up watchdog may be
//! fed. Sampling waits for the first design, so every way the start-up can stall (a design that
//! fails, a sensor that never answers or never has new data, a design that never returns) is
//! decided here, where the host tests it (`tests/startup.rs`); the firmware's humidity task only
//! feeds it the outcome of each poll and of each design.
//!
//! Policy:
//! - the first poll that gives a reading asks for a design at it;
//! - the first poll that gives none (no response, an implausible value, no new data) asks for a
//!   design at the fallback humidity, clamped into the calibration's range, marked `fallback`
//!   so the stream can flag it; a later reading retunes as any humidity change does;
//! - a failed design is asked for again [`RETRY_MS`] later, at the latest reading (the fallback
//!   while there is none), until one succeeds;
//! - the watchdog is fed while the start-up makes progress: not after the first design (the
//!   sample path feeds it from then on), nor while a design has been outstanding for longer
//!   than [`DESIGN_DEADLINE_MS`] (a design that hangs resets the board).

use crate::calibration::laws::Calibration;

/// Wait after a failed design before asking again [ms].
pub const RETRY_MS: u64 = 5_000;
/// Longest a design may take before the start-up counts as hung [ms]. A retune is ~0.5 M
/// instructions (`cargo xtask bench`): milliseconds at 80 MHz, so two seconds is no design.
pub const DESIGN_DEADLINE_MS: u64 = 2_000;

/// What one humidity poll gave.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Poll {
    /// A reading: the strip's humidity for it [%], through the calibration's humidity path and
    /// clamped to the calibrated range (`block_humidity::BlockHumidity`).
    Reading(f32),
    /// The sensor answered, with no sample newer than the last.
    NothingNew,
    /// No answer, or one that is no humidity.
    Failed,
}

/// What a design that was asked for came to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Designed {
    Ok,
    Failed,
}

/// A design to ask for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Request {
    pub rh_pct: f32,
    /// At the fallback humidity: no reading had arrived.
    pub fallback: bool,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Phase {
    /// Nothing asked for yet.
    Idle,
    /// A design was asked for at `since_ms` and has not reported.
    Designing { since_ms: u64 },
    /// The last design failed at `at_ms`.
    Failed { at_ms: u64 },
    /// The first design succeeded: start-up is over.
    Done,
}

#[derive(Clone, Copy, Debug)]
pub struct Startup {
    fallback_pct: f32,
    latest: Option<f32>,
    phase: Phase,
}

impl Startup {
    /// `fallback_pct` is clamped into `calib`'s range here, once.
    pub fn new(calib: &Calibration, fallback_pct: f32) -> Self {
        Startup { fallback_pct: calib.clamp_rh(fallback_pct).0, latest: None, phase: Phase::Idle }
    }

    /// One poll at `now_ms` (any monotonic clock), with the outcome of the design asked for
    /// last if it has reported since the previous poll. Returns the design to ask for, if any.
    pub fn poll(&mut self, now_ms: u64, poll: Poll, designed: Option<Designed>) -> Option<Request> {
        match (self.phase, designed) {
            (Phase::Designing { .. }, Some(Designed::Ok)) => self.phase = Phase::Done,
            (Phase::Designing { .. }, Some(Designed::Failed)) => self.phase = Phase::Failed { at_ms: now_ms },
            _ => {}
        }
        if let Poll::Reading(rh) = poll {
            self.latest = Some(rh);
        }
        let due = match self.phase {
            Phase::Idle => true,
            Phase::Failed { at_ms } => now_ms.saturating_sub(at_ms) >= RETRY_MS,
            Phase::Designing { .. } | Phase::Done => false,
        };
        if !due {
            return None;
        }
        self.phase = Phase::Designing { since_ms: now_ms };
        Some(match self.latest {
            Some(rh_pct) => Request { rh_pct, fallback: false },
            None => Request { rh_pct: self.fallback_pct, fallback: true },
        })
    }

    /// The first design succeeded.
    pub fn is_done(&self) -> bool {
        self.phase == Phase::Done
    }

    /// Whether the start-up path may feed the watchdog at `now_ms`.
    pub fn feeds_watchdog(&self, now_ms: u64) -> bool {
        match self.phase {
            Phase::Done => false,
            Phase::Designing { since_ms } => now_ms.saturating_sub(since_ms) <= DESIGN_DEADLINE_MS,
            Phase::Idle | Phase::Failed { .. } => true,
        }
    }
}
