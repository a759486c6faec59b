//! The calibration's `[departures]` table: each parameter's departure on a grid of humidities
//! that holds every level.

use super::model::StripModel;
use ipmc_core::calibration::departures::{MAX_DEPARTURE_POINTS, MAX_LN_DEPARTURE};

/// The departures table over `rh_range`: [`MAX_DEPARTURE_POINTS`] humidities, each
/// parameter's departure there plus `law_misfit(k, x)` (what the written law leaves of the
/// model's law), clamped to what a table may hold.
///
/// The grid holds every level's humidity, then the midpoints of its widest gaps: the table
/// interpolates linearly, and an even grid would cut a departure shorter than its step to a
/// fraction of itself at the very level that measured it.
pub fn table(model: &StripModel, rh_range: (f64, f64), law_misfit: &dyn Fn(usize, f64) -> f64) -> (Vec<f64>, [Vec<f64>; 4]) {
    let grid = table_grid(&model.positions(), rh_range, MAX_DEPARTURE_POINTS);
    let ln = core::array::from_fn(|k| {
        grid.iter().map(|&x| (model.departure(k, x) + law_misfit(k, x)).clamp(-MAX_LN_DEPARTURE, MAX_LN_DEPARTURE)).collect()
    });
    (grid, ln)
}

/// `n` ascending humidities over `range`: its ends, the `levels` inside it, then the midpoint of
/// the widest gap, one at a time.
fn table_grid(levels: &[f64], range: (f64, f64), n: usize) -> Vec<f64> {
    let mut grid: Vec<f64> =
        [range.0, range.1].into_iter().chain(levels.iter().copied().filter(|x| *x > range.0 && *x < range.1)).collect();
    grid.sort_by(f64::total_cmp);
    grid.dedup_by(|a, b| (*a - *b).abs() < 1e-9);
    if grid.len() > n {
        // More levels than points: evenly through them, both ends kept.
        let all = grid;
        grid = (0..n).map(|i| all[(i * (all.len() - 1) + (n - 1) / 2) / (n - 1)]).collect();
    }
    while grid.len() < n {
        let Some(i) = (0..grid.len() - 1).max_by(|&a, &b| (grid[a + 1] - grid[a]).total_cmp(&(grid[b + 1] - grid[b]))) else { break };
        if grid[i + 1] - grid[i] < 1e-6 {
            break;
        }
        grid.insert(i + 1, 0.5 * (grid[i] + grid[i + 1]));
    }
    grid
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_grid_holds_every_level_and_fills_the_widest_gaps() {
        let g = table_grid(&[40.0, 45.0, 60.0, 20.0], (38.0, 62.0), 8);
        assert_eq!(g.len(), 8);
        for x in [38.0, 40.0, 45.0, 60.0, 62.0] {
            assert!(g.contains(&x), "{x} in {g:?}");
        }
        assert!(!g.contains(&20.0));
        assert!(g.windows(2).all(|w| w[1] > w[0]));
        // The 15 %RH gap is split first, into 3.75 %RH steps.
        assert!(g.contains(&52.5) && g.contains(&48.75) && g.contains(&56.25), "{g:?}");
        // More levels than points: the ends stay, the rest evenly through the levels.
        let many: Vec<f64> = (0..60).map(|i| 20.0 + i as f64).collect();
        let g = table_grid(&many, (19.5, 80.0), 8);
        assert_eq!(g.len(), 8);
        assert_eq!((g[0], g[7]), (19.5, 80.0));
        assert!(g.windows(2).all(|w| w[1] > w[0]), "{g:?}");
    }
}
