//! Figures rendered as SVG and PNG (written atomically), with labels in DejaVu Sans registered
//! once per process.

use anyhow::{Context, Result, anyhow};
use ipmc_recording::write_atomically;
use plotters::coord::Shift;
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Where Debian's `fonts-dejavu-core` (and other distributions) put DejaVu Sans.
const FONT_PATHS: [&str; 3] =
    ["/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf", "/usr/share/fonts/dejavu/DejaVuSans.ttf"];

/// A figure drawable on any backend.
pub trait Figure {
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<()>
    where
        DB::ErrorType: 'static;
}

/// Turns a plotters error into ours.
pub fn pe<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("drawing failed: {e:?}")
}

/// Registers the label font once per process.
pub fn register_font() -> Result<()> {
    static FONT: OnceLock<Result<(), String>> = OnceLock::new();
    FONT.get_or_init(|| {
        let path = FONT_PATHS.iter().map(PathBuf::from).find(|p| p.exists()).ok_or_else(|| {
            "no TrueType font for the plot labels: install DejaVu Sans (Debian: apt-get install fonts-dejavu-core)".to_string()
        })?;
        let bytes: &'static [u8] = Box::leak(std::fs::read(&path).map_err(|e| format!("{}: {e}", path.display()))?.into_boxed_slice());
        plotters::style::register_font("sans-serif", FontStyle::Normal, bytes)
            .map_err(|_| format!("{}: not a TrueType font", path.display()))
    })
    .clone()
    .map_err(|e| anyhow!(e))
}

/// Writes `prefix`.svg and `prefix`.png of `fig` at `size` pixels; returns their paths.
pub fn render(fig: &impl Figure, prefix: &Path, size: (u32, u32)) -> Result<(PathBuf, PathBuf)> {
    register_font()?;
    let (svg_path, png_path) = (prefix.with_extension("svg"), prefix.with_extension("png"));
    if let Some(d) = svg_path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(d).with_context(|| format!("cannot create {}", d.display()))?;
    }
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        fig.draw(&root)?;
        root.present().map_err(pe)?;
    }
    write_atomically(&svg_path, svg.as_bytes())?;
    let mut rgb = vec![0u8; (size.0 * size.1 * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        fig.draw(&root)?;
        root.present().map_err(pe)?;
    }
    let mut png_bytes = Vec::new();
    {
        let mut enc = png::Encoder::new(&mut png_bytes, size.0, size.1);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().context("PNG encoder")?;
        w.write_image_data(&rgb).context("PNG encoder")?;
    }
    write_atomically(&png_path, &png_bytes)?;
    Ok((svg_path, png_path))
}
