//! The firmware's start-up state machine (`ipmc_core::firmware::startup`) driven as the humidity task
//! drives it: one poll a second, a sensor and a designer scripted per test. QEMU has no
//! watchdog and its replayed sensor always answers at start, so these are the tests of a
//! start-up that must not hang.

use ipmc_core::{
    Calibration,
    firmware::startup::{DESIGN_DEADLINE_MS, Designed, Poll, RETRY_MS, Request, Startup},
};

const PERIOD_MS: u64 = 1_000;
const FALLBACK_PCT: f32 = 50.0;

/// What happened at one poll.
#[derive(Debug)]
struct Step {
    now_ms: u64,
    request: Option<Request>,
    fed: bool,
}

/// Runs `seconds` polls. `sensor(i)` is poll i's outcome; `designer(k, request)` is the outcome
/// of the k-th design asked for (None: it never reports), reported at the next poll.
fn run(
    calib: &Calibration,
    seconds: u64,
    sensor: impl Fn(u64) -> Poll,
    designer: impl Fn(usize, Request) -> Option<Designed>,
) -> (Vec<Step>, Startup) {
    let mut s = Startup::new(calib, FALLBACK_PCT);
    let mut pending: Option<Designed> = None;
    let mut asked = 0;
    let mut steps = Vec::new();
    for i in 0..seconds {
        let now_ms = i * PERIOD_MS;
        let request = s.poll(now_ms, sensor(i), pending.take());
        if let Some(r) = request {
            pending = designer(asked, r);
            asked += 1;
        }
        steps.push(Step { now_ms, request, fed: s.feeds_watchdog(now_ms) });
    }
    (steps, s)
}

fn requests(steps: &[Step]) -> Vec<(u64, Request)> {
    steps.iter().filter_map(|s| s.request.map(|r| (s.now_ms, r))).collect()
}

fn narrow_calibration() -> Calibration {
    let mut c = Calibration::default_preset();
    c.rh_min = 60.0;
    c
}

#[test]
fn a_sensor_that_never_has_data_starts_at_the_fallback_clamped_into_the_range() {
    let calib = narrow_calibration();
    let (steps, s) = run(&calib, 10, |_| Poll::NothingNew, |_, _| Some(Designed::Ok));
    let asked = requests(&steps);
    // At the first poll, not after a grace period; at the range's floor, not at 50 %.
    assert_eq!(asked, vec![(0, Request { rh_pct: 60.0, fallback: true })], "{steps:?}");
    assert!(s.is_done());
    // Fed until the design is in, then the sample path's job.
    assert!(steps[0].fed);
    assert!(steps[1..].iter().all(|s| !s.fed), "{steps:?}");
}

#[test]
fn a_dead_sensor_starts_at_the_fallback_inside_the_range_unchanged() {
    let (steps, _) = run(&Calibration::default_preset(), 3, |_| Poll::Failed, |_, _| Some(Designed::Ok));
    assert_eq!(requests(&steps), vec![(0, Request { rh_pct: FALLBACK_PCT, fallback: true })]);
}

#[test]
fn the_first_reading_is_designed_at() {
    let (steps, s) = run(&Calibration::default_preset(), 3, |_| Poll::Reading(42.5), |_, _| Some(Designed::Ok));
    assert_eq!(requests(&steps), vec![(0, Request { rh_pct: 42.5, fallback: false })]);
    assert!(s.is_done());
}

#[test]
fn a_failed_design_is_retried_every_five_seconds_at_the_latest_reading() {
    // No reading for 7 s, then readings of 35 % and 36 %; the first three designs fail.
    let sensor = |i: u64| match i {
        0..7 => Poll::Failed,
        7..9 => Poll::Reading(35.0),
        _ => Poll::Reading(36.0),
    };
    let (steps, s) = run(&Calibration::default_preset(), 30, sensor, |k, _| Some(if k < 3 { Designed::Failed } else { Designed::Ok }));
    let asked = requests(&steps);
    // Asked at 0 s (fails, reported at 1 s), again 5 s after the failure: 6 s, still no reading;
    // 12 s at the latest reading (36 % since 9 s); 18 s, which succeeds.
    let retry_s = RETRY_MS / PERIOD_MS;
    assert_eq!(
        asked,
        vec![
            (0, Request { rh_pct: FALLBACK_PCT, fallback: true }),
            ((1 + retry_s) * PERIOD_MS, Request { rh_pct: FALLBACK_PCT, fallback: true }),
            ((2 + 2 * retry_s) * PERIOD_MS, Request { rh_pct: 36.0, fallback: false }),
            ((3 + 3 * retry_s) * PERIOD_MS, Request { rh_pct: 36.0, fallback: false }),
        ],
        "{steps:?}"
    );
    assert!(s.is_done());
    // A start-up that keeps trying is alive: fed all along until the design is in.
    let done_at = (4 + 3 * retry_s) as usize;
    assert!(steps[..done_at].iter().all(|s| s.fed), "{steps:?}");
    assert!(steps[done_at..].iter().all(|s| !s.fed), "{steps:?}");
}

#[test]
fn designs_that_always_fail_are_retried_for_ever() {
    let (steps, s) = run(&Calibration::default_preset(), 60, |_| Poll::NothingNew, |_, _| Some(Designed::Failed));
    let asked = requests(&steps);
    assert_eq!(asked.len() as u64, 1 + (60 - 1) / (1 + RETRY_MS / PERIOD_MS), "{asked:?}");
    assert!(asked.windows(2).all(|w| w[1].0 - w[0].0 == PERIOD_MS + RETRY_MS));
    assert!(!s.is_done());
    assert!(steps.iter().all(|s| s.fed));
}

#[test]
fn a_design_that_never_returns_stops_the_feeding() {
    let (steps, s) = run(&Calibration::default_preset(), 10, |_| Poll::Reading(45.0), |_, _| None);
    assert_eq!(requests(&steps).len(), 1, "a hung design is not asked for again");
    assert!(!s.is_done());
    for st in &steps {
        assert_eq!(st.fed, st.now_ms <= DESIGN_DEADLINE_MS, "{st:?}");
    }
}

#[test]
fn a_late_design_outcome_without_a_request_changes_nothing() {
    let mut s = Startup::new(&Calibration::default_preset(), FALLBACK_PCT);
    // An outcome before anything was asked for (none can come, but it must not end start-up).
    assert_eq!(s.poll(0, Poll::Failed, Some(Designed::Ok)), Some(Request { rh_pct: FALLBACK_PCT, fallback: true }));
    assert!(!s.is_done());
}
