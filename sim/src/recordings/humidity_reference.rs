//! Humidity-reference recordings (recording-format.md §4): a session's humidity sensor read in
//! sealed jars over saturated salt solutions, the same sensor model the chamber's readings use
//! (`world::bench::reading`), against references whose humidity is itself known only so well.

use crate::session::Session;
use crate::world::bench::reading;
use crate::world::surroundings::Room;
use ipmc_fit::random::SplitMix64;
use ipmc_recording::{HumidityReference, Metadata};

/// The salts and their humidity at 25 °C [%RH].
pub const SALTS: [(&str, f64); 3] = [("MgCl2", 32.8), ("K2CO3", 43.2), ("NaCl", 75.3)];
/// How far a jar's humidity may be from its salt's tabulated value [±%RH, 1σ].
pub const SALT_UNCERTAINTY_PCT: f64 = 0.3;
pub const READINGS_PER_SALT: usize = 20;
/// One reading a minute once the sensor has equilibrated in the jar [s].
const READING_INTERVAL_S: f64 = 60.0;

/// `session`'s sensor (its span, offset, held and per-reading errors) and thermometer read in
/// each salt's jar; the session's seed draws the jars' own errors and the readings.
pub fn simulate(session: &Session, mut metadata: Metadata) -> HumidityReference {
    let h = &session.humidity;
    let mut rng = SplitMix64(session.seed);
    let room = Room::draw(session, &mut rng);
    metadata.set("salts", SALTS.map(|(salt, rh)| format!("{salt} {rh}")).join(","));
    metadata.set("readings", format!("{READINGS_PER_SALT} per salt, one a minute after equilibration"));
    let n = SALTS.len() * READINGS_PER_SALT;
    let mut r = HumidityReference {
        metadata,
        reference: "saturated salts".into(),
        reference_uncertainty_pct: SALT_UNCERTAINTY_PCT,
        reference_rh_pct: Vec::with_capacity(n),
        rh_pct: Vec::with_capacity(n),
        temp_c: session.temp_c.map(|_| Vec::with_capacity(n)),
    };
    let mut t = 0.0;
    for (_, tabulated) in SALTS {
        let in_jar = tabulated + rng.gauss(SALT_UNCERTAINTY_PCT);
        let held = rng.gauss(h.level_read_error_pct);
        for _ in 0..READINGS_PER_SALT {
            r.reference_rh_pct.push(tabulated);
            r.rh_pct.push(reading(h, in_jar, held, &mut rng));
            if let (Some(v), Some(temp)) = (r.temp_c.as_mut(), room.at(t)) {
                v.push(temp + rng.gauss(session.temp_read_error_k));
            }
            t += READING_INTERVAL_S;
        }
    }
    r
}
