//! `ipmc plot`'s figures: each module draws one kind of figure on any plotters backend
//! (`bode`, `compensated`, `params`, `residual_map`; made from files by `from_files`); `output`
//! renders them as SVG and PNG (written atomically) with labels in DejaVu Sans, on the axes,
//! units and colours of `scales` and with the markers and legends of `legend`.

pub mod bode;
pub mod compensated;
pub mod from_files;
pub mod legend;
pub mod output;
pub mod params;
pub mod residual_map;
pub mod scales;

pub use legend::{LegendEntry, Marker, draw_markers, legend_width, side_legend};
pub use output::{Figure, pe, register_font, render};
pub use scales::{
    humidity_color, humidity_color_in, log_axis, log_tick_label, log_ticks, round_sig, scaled_unit, span_tick_label, superscript,
    tick_label,
};
