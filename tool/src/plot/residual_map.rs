//! Heat maps of normalized residuals (residual/σ) over frequency × humidity level, one panel per
//! model (e.g. before and after a diagnosis's augmentation), on one colour scale.

use super::{Figure, log_axis, pe, tick_label};
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
            // Rows from the top in time order, two units high so that each row's label sits at
            // its centre (an odd key point): every row is labelled, however many there are.
            let labels: Vec<String> = panel.rows.iter().enumerate().map(|(i, r)| format!("#{}  {:.1} %", i + 1, r.rh_pct)).collect();
            let centres: Vec<i32> = (0..n as i32).map(|i| 2 * i + 1).collect();
            let row_of = |y: i32| n.checked_sub(1 + (y.max(0) / 2) as usize);
            let font_px = ((area.dim_in_pixel().1 as f64 - 110.0) / n.max(1) as f64 * 0.75).clamp(8.0, 14.0);
            let first_freq = panel.rows.iter().filter_map(|r| r.cells.first().map(|c| c.0)).fold(f64::INFINITY, f64::min);
            let last_freq = panel.rows.iter().filter_map(|r| r.cells.last().map(|c| c.0)).fold(0.0, f64::max);
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, ("sans-serif", 18))
                .margin(10)
                .x_label_area_size(40)
                .y_label_area_size(100)
                .build_cartesian_2d(log_axis(f_lo, f_hi, &[first_freq, last_freq]), (0..2 * n as i32).with_key_points(centres))
                .map_err(pe)?;
            chart
                .configure_mesh()
                .disable_mesh()
                .x_desc("f [Hz]")
                .y_desc("level # and RH, in time order from the top")
                .x_label_formatter(&|v| tick_label(*v))
                .y_label_formatter(&|v| row_of(*v).and_then(|r| labels.get(r)).cloned().unwrap_or_default())
                .label_style(("sans-serif", 14))
                .y_label_style(("sans-serif", font_px))
                .draw()
                .map_err(pe)?;
            for (i, (row, e)) in panel.rows.iter().zip(&cell_edges).enumerate() {
                let y = 2 * (n - 1 - i) as i32;
                chart
                    .draw_series(
                        row.cells
                            .iter()
                            .enumerate()
                            .filter_map(|(k, (_, v))| v.map(|v| Rectangle::new([(e[k], y), (e[k + 1], y + 2)], color_of(v).filled()))),
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
        for k in 1..SATURATION as i32 {
            let x = x0 + steps * dx * k / SATURATION as i32;
            bar.draw(&PathElement::new(vec![(x, 30), (x, 35)], BLACK.stroke_width(1))).map_err(pe)?;
            bar.draw(&Text::new(k.to_string(), (x - 4, 37), ("sans-serif", 14).into_font())).map_err(pe)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every row of a map of 19 levels is labelled with its number and humidity, the hottest too.
    #[test]
    fn every_row_is_labelled() {
        let rows: Vec<Row> = (0..19)
            .map(|i| Row {
                rh_pct: 35.0 + 2.5 * i as f64,
                cells: [10.0, 20.0, 50.0, 150.0].iter().map(|&f| (f, Some(if i == 9 { 9.0 } else { 1.0 }))).collect(),
            })
            .collect();
        let map = ResidualMap { title: "test".into(), panels: vec![Panel { title: "before".into(), rows }] };
        super::super::register_font().unwrap();
        let mut svg = String::new();
        {
            let root = SVGBackend::with_string(&mut svg, (1600, 800)).into_drawing_area();
            map.draw(&root).unwrap();
            root.present().unwrap();
        }
        for i in 0..19 {
            let label = format!("#{}  {:.1} %", i + 1, 35.0 + 2.5 * i as f64);
            assert!(svg.contains(&label), "row {} unlabelled ({label})", i + 1);
        }
        assert!(svg.contains(">\n150\n<") || svg.contains(">150<"), "no tick at the data's end");
    }
}
