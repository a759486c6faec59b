//! Markers of data points and the legend beside a figure.

use super::output::pe;
use anyhow::Result;
use plotters::coord::Shift;
use plotters::prelude::*;

/// A data point's marker shape.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Marker {
    Circle,
    Square,
    Triangle,
    Diamond,
}

impl Marker {
    pub const ALL: [Marker; 4] = [Marker::Circle, Marker::Square, Marker::Triangle, Marker::Diamond];
}

/// Runs `$body` with `$e` bound to the element of marker `$shape` at `$at` (half-size `$r`
/// pixels, `$filled` or an outline in `$color`): each shape is its own element type.
macro_rules! with_marker {
    ($shape:expr, $filled:expr, $at:expr, $r:expr, $color:expr, |$e:ident| $body:expr) => {{
        let (r, filled, color): (i32, bool, RGBColor) = ($r, $filled, $color);
        let style = if filled { color.filled() } else { color.stroke_width(2) };
        let triangle = vec![(0, -r - 1), (r + 1, r), (-r - 1, r)];
        let diamond = vec![(0, -r - 1), (r + 1, 0), (0, r + 1), (-r - 1, 0)];
        let closed = |mut v: Vec<(i32, i32)>| {
            v.push(v[0]);
            v
        };
        match ($shape, filled) {
            (Marker::Circle, _) => {
                let $e = EmptyElement::at($at) + Circle::new((0, 0), r, style);
                $body
            }
            (Marker::Square, _) => {
                let $e = EmptyElement::at($at) + Rectangle::new([(-r + 1, -r + 1), (r - 1, r - 1)], style);
                $body
            }
            (Marker::Triangle, true) => {
                let $e = EmptyElement::at($at) + Polygon::new(triangle.clone(), style);
                $body
            }
            (Marker::Diamond, true) => {
                let $e = EmptyElement::at($at) + Polygon::new(diamond.clone(), style);
                $body
            }
            (Marker::Triangle, false) => {
                let $e = EmptyElement::at($at) + PathElement::new(closed(triangle.clone()), style);
                $body
            }
            (Marker::Diamond, false) => {
                let $e = EmptyElement::at($at) + PathElement::new(closed(diamond.clone()), style);
                $body
            }
        }
    }};
}

/// Draws `points` on `chart` as markers of `shape` (half-size `size` pixels), filled or hollow.
pub fn draw_markers<DB: DrawingBackend, CT: CoordTranslate<From = (f64, f64)>>(
    chart: &mut ChartContext<'_, DB, CT>,
    points: &[(f64, f64)],
    shape: Marker,
    size: i32,
    color: RGBColor,
    filled: bool,
) -> Result<()>
where
    DB::ErrorType: 'static,
{
    for &p in points {
        with_marker!(shape, filled, p, size, color, |e| chart.plotting_area().draw(&e).map_err(pe)?);
    }
    Ok(())
}

/// One entry of a [`side_legend`]: a line sample (solid or dashed) and/or a marker, then the label.
pub struct LegendEntry {
    pub label: String,
    pub color: RGBColor,
    /// `Some(dashed)` draws a line sample.
    pub line: Option<bool>,
    /// `Some((shape, filled))` draws a marker.
    pub marker: Option<(Marker, bool)>,
}

/// Font of legend entries.
const LEGEND_FONT: u32 = 14;

/// Width in pixels a [`side_legend`] of `entries` (and `title`) needs.
pub fn legend_width<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, title: Option<&str>, entries: &[LegendEntry]) -> u32 {
    let font: TextStyle = ("sans-serif", LEGEND_FONT).into();
    let text = |s: &str| area.estimate_text_size(s, &font).map_or(s.chars().count() as u32 * 8, |(w, _)| w);
    let widest = entries.iter().map(|e| text(&e.label) + 52).chain(title.map(text)).max().unwrap_or(0);
    widest + 24
}

/// A legend in its own area beside the plots (never over data): `title` and then one entry per
/// line from the top.
pub fn side_legend<DB: DrawingBackend>(area: &DrawingArea<DB, Shift>, title: Option<&str>, entries: &[LegendEntry]) -> Result<()>
where
    DB::ErrorType: 'static,
{
    let (w, h) = area.dim_in_pixel();
    let font = ("sans-serif", LEGEND_FONT).into_font();
    let x0 = 10;
    let mut y = 50;
    if let Some(t) = title {
        area.draw(&Text::new(t.to_string(), (x0, y), ("sans-serif", LEGEND_FONT + 1).into_font())).map_err(pe)?;
        y += 26;
    }
    let step = ((h as i32 - y - 20) / entries.len().max(1) as i32).clamp(12, 24);
    let top = y - 8;
    for e in entries {
        let mid = y + LEGEND_FONT as i32 / 2;
        if let Some(dashed) = e.line {
            let style = e.color.stroke_width(2);
            if dashed {
                for k in 0..3 {
                    area.draw(&PathElement::new(vec![(x0 + k * 12, mid), (x0 + k * 12 + 7, mid)], style)).map_err(pe)?;
                }
            } else {
                area.draw(&PathElement::new(vec![(x0, mid), (x0 + 32, mid)], style)).map_err(pe)?;
            }
        }
        if let Some((shape, filled)) = e.marker {
            if !filled {
                area.draw(&Rectangle::new([(x0 + 10, mid - 6), (x0 + 22, mid + 6)], WHITE.filled())).map_err(pe)?;
            }
            with_marker!(shape, filled, (x0 + 16, mid), 4, e.color, |m| area.draw(&m).map_err(pe)?);
        }
        area.draw(&Text::new(e.label.clone(), (x0 + 42, y), font.clone())).map_err(pe)?;
        y += step;
    }
    area.draw(&Rectangle::new([(2, top), (w as i32 - 4, y + 4)], BLACK.stroke_width(1))).map_err(pe)?;
    Ok(())
}
