//! Heat maps of normalized residuals (residual/σ) over frequency × humidity level, one panel per
//! model (e.g. before and after a diagnosis's augmentation), on one colour scale.

use super::{Figure, pe};
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// One humidity level's row: its humidity and, per frequency, the residual/σ (None: not measured).
pub struct Row {
    pub rh_pct: f64,
    pub cells: Vec<(f64, Option<f64>)>,
}

/// One panel: a model's residual rows.
pub struct Panel {
    pub title: String,
    pub rows: Vec<Row>,
}

pub struct ResidualMap {
    pub title: String,
    pub panels: Vec<Panel>,
}

/// |residual|/σ at which the colour saturates: 3σ is rare noise, beyond is structure.
const SATURATION: f64 = 4.0;

/// White at 0 through yellow and orange to dark red at [`SATURATION`].
fn color_of(v: f64) -> RGBColor {
    let x = (v / SATURATION).clamp(0.0, 1.0);
    let lerp = |a: f64, b: f64, t: f64| (a + (b - a) * t).round() as u8;
    if x < 0.5 {
        let t = x / 0.5;
        RGBColor(255, lerp(255.0, 200.0, t), lerp(255.0, 40.0, t))
    } else {
        let t = (x - 0.5) / 0.5;
        RGBColor(lerp(255.0, 140.0, t), lerp(200.0, 0.0, t), lerp(40.0, 0.0, t))
    }
}

/// Cell edges between neighbouring frequencies (geometric midpoints), extended half a step out.
fn edges(freqs: &[f64]) -> Vec<f64> {
    let n = freqs.len();
    if n == 1 {
        return vec![freqs[0] / 1.1, freqs[0] * 1.1];
    }
    let mut e = Vec::with_capacity(n + 1);
    e.push(freqs[0] / (freqs[1] / freqs[0]).sqrt());
    for k in 1..n {
        e.push((freqs[k - 1] * freqs[k]).sqrt());
    }
    e.push(freqs[n - 1] * (freqs[n - 1] / freqs[n - 2]).sqrt());
    e
}

impl Figure for ResidualMap {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static,
    {
        root.fill(&WHITE).map_err(pe)?;
        let root = root.titled(&self.title, ("sans-serif", 22)).map_err(pe)?;
        let (maps, bar) = root.split_vertically(root.dim_in_pixel().1.saturating_sub(60));
        let panels = maps.split_evenly((1, self.panels.len().max(1)));
        for (panel, area) in self.panels.iter().zip(panels.iter()) {
            let cell_edges: Vec<Vec<f64>> = panel.rows.iter().map(|r| edges(&r.cells.iter().map(|c| c.0).collect::<Vec<_>>())).collect();
            let (f_lo, f_hi) = cell_edges.iter().flatten().fold((f64::INFINITY, 0.0f64), |(a, b), f| (a.min(*f), b.max(*f)));
            let n = panel.rows.len();
            let labels: Vec<String> = panel.rows.iter().map(|r| format!("{:.1} %", r.rh_pct)).collect();
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(34)
                .y_label_area_size(70)
                .build_cartesian_2d((f_lo..f_hi).log_scale(), 0.0..n as f64)
                .map_err(pe)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("f [Hz]")
                .y_desc("humidity level (time order)")
                .x_label_formatter(&|v| format!("{v:.0}"))
                .y_labels(n.min(20))
                .y_label_formatter(&|v| labels.get(v.floor() as usize).cloned().unwrap_or_default())
                .draw()
                .map_err(pe)?;
            for (i, (row, e)) in panel.rows.iter().zip(&cell_edges).enumerate() {
                let y = i as f64;
                chart
                    .draw_series(
                        row.cells
                            .iter()
                            .enumerate()
                            .filter_map(|(k, (_, v))| v.map(|v| Rectangle::new([(e[k], y), (e[k + 1], y + 1.0)], color_of(v).filled()))),
                    )
                    .map_err(pe)?;
            }
        }
        // Colour scale.
        let steps = 40;
        let (w, _) = bar.dim_in_pixel();
        let x0 = (w as i32) / 4;
        let dx = ((w as i32) / 2) / steps;
        for k in 0..steps {
            let v = SATURATION * (k as f64 + 0.5) / steps as f64;
            bar.draw(&Rectangle::new([(x0 + k * dx, 10), (x0 + (k + 1) * dx, 30)], color_of(v).filled())).map_err(pe)?;
        }
        bar.draw(&Rectangle::new([(x0, 10), (x0 + steps * dx, 30)], BLACK.stroke_width(1))).map_err(pe)?;
        let font = ("sans-serif", 16).into_font();
        bar.draw(&Text::new("|residual| / σ:  0".to_string(), (x0 - 150, 12), font.clone())).map_err(pe)?;
        bar.draw(&Text::new(format!("≥ {SATURATION:.0}"), (x0 + steps * dx + 8, 12), font)).map_err(pe)?;
        Ok(())
    }
}
