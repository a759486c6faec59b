//! Where a chamber's stated setpoints place the bench levels on the humidity axis.
//!
//! Each level's humidity has two accounts: the bench sensor's reading, off by a read error of
//! σₑ per visit and by the sensor's bias over the session, and the chamber's setpoint, which the
//! chamber holds to within its own σ_c. The setpoints are the scale: a chamber is the reference
//! a lab checks its sensors against, while a capacitive sensor's offset moves from session to
//! session (drift, hysteresis after the wet end), and one session cannot tell a sensor's bias
//! from a chamber's offset. The readings' scatter about the setpoints says how far the chamber
//! held them: beyond what σₑ explains, the scatter is the chamber's. Per setpoint visited (a
//! site: its visits share one humidity), with dᵍ = r̄ᵍ − Sᵍ and uᵍ = σₑ²/nᵍ,
//!
//!   dᵍ ~ N(b, σ_c² + uᵍ),  wᵍ = 1/(σ_c² + uᵍ),  b̂ = Σwᵍdᵍ/Σwᵍ,
//!
//! b the sensor's bias this session. The site sits at Sᵍ + λᵍ(dᵍ − b̂), λᵍ = σ_c²/(σ_c² + uᵍ):
//! where the chamber holds its setpoints better than the sensor reads them, at the setpoint.
//! σ_c is the restricted likelihood's maximum (b integrated out), as every other variance of
//! the model is ([`crate::departures`]), found on a grid from 0 to four times the larger of the
//! readings' spread and a level's read error.
//!
//! Why it matters: at the wet end d changes by a quarter per %RH and Y by 4 %, so a top level
//! read 0.4 %RH high, placed at its reading, bends both laws there; a strip departure of the
//! same sign is then read as a read error, and a service reading a percent off the level
//! misses by both. And a session's bias of 0.4 %RH, kept, moves every level by 11 % in d.
//!
//! What is left unknown of a site's humidity: λᵍuᵍ of its own, plus λᵃλᵇ/Σw shared through b.
//! Not in it: how well σ_c itself is known (a top level read once may move the levels through
//! it, which identify's check of the range's ends measures and warns of), and the chamber's own
//! accuracy, which nothing in a session measures.

/// Points of the grid σ_c's likelihood is searched on, from 0 to four times the larger of the
/// readings' spread and a level's read error.
const CHAMBER_GRID: usize = 161;

/// Fewest setpoints visited the chamber's scatter is taken from: with fewer, the readings' spread
/// about them says nothing of it.
pub const MIN_SITES: usize = 3;

/// The levels placed by their setpoints and readings.
#[derive(Clone, Debug, PartialEq)]
pub struct Placement {
    /// Per level, its humidity: its site's.
    pub position: Vec<f64>,
    /// Per level, the weight of its site's reading against its setpoint (λ; 0: the setpoint).
    pub reading_weight: Vec<f64>,
    /// The chamber's scatter about its setpoints [%RH] (σ_c).
    pub chamber_sd_pct: f64,
    /// The bench sensor's bias this session, the readings' mean offset from the setpoints (b),
    /// and its standard error [%RH].
    pub sensor_bias_pct: f64,
    pub sensor_bias_sd_pct: f64,
}

impl Placement {
    /// The covariance of the errors of two levels' placed humidities: each site's own part
    /// (`own`, its mean reading's variance σₑ²/n) times its reading's weight where the two are
    /// one site, and the bias's shared part.
    pub fn input_cov(&self, ia: usize, ib: usize, same_site: bool, own: f64) -> f64 {
        let (la, lb) = (self.reading_weight[ia], self.reading_weight[ib]);
        let shared = la * lb * self.sensor_bias_sd_pct.powi(2);
        if same_site { la * own + shared } else { shared }
    }
}

/// The placement of levels with mean readings `reading` (each level's site's mean), stated
/// setpoints `setpoint`, sites `site` (each level's first visit) and visits per site `visits`,
/// the reading's error per visit `read_sd`. None unless every level states a setpoint, its
/// visits agree on it and at least [`MIN_SITES`] sites do.
pub fn place(reading: &[f64], setpoint: &[Option<f64>], site: &[usize], visits: &[usize], read_sd: f64) -> Option<Placement> {
    let n = reading.len();
    if setpoint.len() != n || setpoint.iter().any(Option::is_none) || !(read_sd.is_finite() && read_sd > 0.0) {
        return None;
    }
    let s = |i: usize| setpoint[i].expect("checked");
    if (0..n).any(|i| s(i) != s(site[i])) {
        return None;
    }
    let firsts: Vec<usize> = (0..n).filter(|&i| site[i] == i).collect();
    let g = firsts.len();
    if g < MIN_SITES {
        return None;
    }
    let d: Vec<f64> = firsts.iter().map(|&i| reading[i] - s(i)).collect();
    let u: Vec<f64> = firsts.iter().map(|&i| read_sd * read_sd / visits[i] as f64).collect();
    let mean_d = d.iter().sum::<f64>() / g as f64;
    let spread = d.iter().map(|x| (x - mean_d).powi(2)).sum::<f64>() / (g - 1) as f64;
    let top = 4.0 * spread.max(u.iter().cloned().fold(0.0, f64::max)).sqrt();
    // Per σ_c on the grid: its restricted log likelihood (the bias integrated out) and the
    // placement it makes; the likeliest is kept.
    let mut best: Option<(f64, Placement)> = None;
    for j in 0..CHAMBER_GRID {
        let sd = top * j as f64 / (CHAMBER_GRID - 1) as f64;
        let var = sd * sd;
        let w: Vec<f64> = u.iter().map(|u| 1.0 / (var + u)).collect();
        let total: f64 = w.iter().sum();
        let bias = w.iter().zip(&d).map(|(w, d)| w * d).sum::<f64>() / total;
        let chi2: f64 = w.iter().zip(&d).map(|(w, d)| w * (d - bias).powi(2)).sum();
        let log_like = 0.5 * (w.iter().map(|w| w.ln()).sum::<f64>() - total.ln() - chi2);
        if best.as_ref().is_some_and(|b| b.0 >= log_like) {
            continue;
        }
        let reading_weight: Vec<f64> = (0..n).map(|i| var / (var + read_sd * read_sd / visits[i] as f64)).collect();
        let position = (0..n).map(|i| s(i) + reading_weight[i] * (reading[i] - s(i) - bias)).collect();
        let placement =
            Placement { position, reading_weight, chamber_sd_pct: sd, sensor_bias_pct: bias, sensor_bias_sd_pct: total.recip().sqrt() };
        best = Some((log_like, placement));
    }
    best.map(|b| b.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sites(n: usize) -> (Vec<usize>, Vec<usize>) {
        ((0..n).collect(), vec![1; n])
    }

    #[test]
    fn a_chamber_that_holds_its_setpoints_places_the_levels_there_whatever_the_sensors_bias() {
        let set: Vec<f64> = (0..8).map(|i| 40.0 + 5.0 * i as f64).collect();
        // Read errors of about 1 %RH and the sensor 0.6 %RH high all session.
        let e = [0.9, -1.1, 0.4, -0.6, 1.3, -0.2, -0.8, 0.1];
        let reading: Vec<f64> = set.iter().zip(e).map(|(s, e)| s + 0.6 + e).collect();
        let (site, visits) = sites(8);
        let p = place(&reading, &set.iter().map(|&s| Some(s)).collect::<Vec<_>>(), &site, &visits, 1.0).unwrap();
        // The readings scatter by 0.84 %RH about their mean, the read error's alone: the levels
        // sit at their setpoints, the bias taken out.
        assert_eq!(p.chamber_sd_pct, 0.0);
        assert!(p.reading_weight.iter().all(|&l| l == 0.0));
        assert_eq!(p.position, set);
        assert!((p.sensor_bias_pct - 0.6).abs() < 1e-9 && (p.sensor_bias_sd_pct - 0.125f64.sqrt()).abs() < 1e-9, "{p:?}");
        assert_eq!(p.input_cov(0, 0, true, 1.0), 0.0);
    }

    #[test]
    fn a_chamber_that_wanders_leaves_the_levels_near_their_readings() {
        let set: Vec<f64> = (0..8).map(|i| 40.0 + 5.0 * i as f64).collect();
        // The chamber 3 %RH off its setpoints here and there, the sensor good to 0.1.
        let off = [3.0, -2.5, 0.5, -3.5, 2.0, -1.0, 4.0, -2.0];
        let reading: Vec<f64> = set.iter().zip(off).map(|(s, o)| s + o).collect();
        let (site, visits) = sites(8);
        let p = place(&reading, &set.iter().map(|&s| Some(s)).collect::<Vec<_>>(), &site, &visits, 0.1).unwrap();
        assert!(p.chamber_sd_pct > 2.0, "{}", p.chamber_sd_pct);
        let bias = off.iter().sum::<f64>() / 8.0;
        for (x, r) in p.position.iter().zip(&reading) {
            assert!((x - (r - bias)).abs() < 0.02, "{x} against the reading {r} less the bias {bias}");
        }
    }

    #[test]
    fn no_placement_without_a_setpoint_for_every_level_or_with_visits_that_disagree() {
        let reading = [40.2, 45.1, 49.7, 55.3];
        let (site, visits) = sites(4);
        assert!(place(&reading, &[Some(40.0), Some(45.0), None, Some(55.0)], &site, &visits, 1.0).is_none());
        assert!(place(&reading[..2], &[Some(40.0), Some(45.0)], &site[..2], &visits[..2], 1.0).is_none());
        // Level 3 revisits level 1's setpoint but states another.
        let site = [0, 1, 2, 0];
        let visits = [2, 1, 1, 2];
        assert!(place(&reading, &[Some(40.0), Some(45.0), Some(50.0), Some(55.0)], &site, &visits, 1.0).is_none());
        assert!(place(&reading, &[Some(40.0), Some(45.0), Some(50.0), Some(40.0)], &site, &visits, 1.0).is_some());
    }
}
