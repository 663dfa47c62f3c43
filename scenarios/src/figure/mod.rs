//! Figures a reader of a paper could use: a title and subtitle, axes with units and readable
//! ticks, a legend with labels, colour bars with units, colour-blind-safe colours
//! ([`colour`]), each written as PNG (1600 px wide) and SVG with real `<text>` elements.
//!
//! Drawn with `plotters` on its bitmap and SVG backends. The text of the PNG is drawn with
//! DejaVu Sans, built into the program (`assets/fonts/`, licence beside it) and registered
//! with plotters' `ab_glyph` support, so no system font is needed; the SVG names the same
//! family (falling back to the viewer's sans-serif).
//!
//! ```no_run
//! use atrium_scenarios::figure::{line_chart, LineChart, Series, Threshold};
//! let fig = line_chart(&LineChart {
//!     title: "Failure rate against corridor width".into(),
//!     x_label: "corridor width (m)".into(),
//!     y_label: "failure rate (%)".into(),
//!     series: vec![Series::new("mcl", vec![(2.0, 10.0), (3.0, 4.0)])
//!         .with_band(vec![(2.0, 6.0, 15.0), (3.0, 1.0, 8.0)])],
//!     thresholds: vec![Threshold::new(5.0, "5 % budget")],
//!     y_from_zero: true,
//!     ..Default::default()
//! })
//! .unwrap();
//! fig.write(std::path::Path::new("out"), "failure_width").unwrap(); // .png and .svg
//! ```

mod chart;
pub mod colour;
mod map;
mod ticks;

pub use chart::{
    heatmap, histogram, line_chart, line_panels, Heatmap, Histogram, LineChart, Sample, Series,
    Threshold,
};
pub use colour::{ColourMap, ColourScale, Rgb};
pub use map::{
    map_figure, LegendEntry, MapBase, MapCells, MapFigure, MapPath, MapShape, ShapeKind, ValuePath,
};
pub use ticks::{format_number, nice_step, nice_ticks};

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::path::{Path, PathBuf};

/// The font family every figure uses (registered once from the bundled DejaVu Sans).
pub const FONT: &str = "DejaVu Sans, sans-serif";
/// Width of every figure, pixels (the PNG's width; the SVG's view box).
pub const WIDTH: u32 = 1600;

const DEJAVU_SANS: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
const DEJAVU_SANS_BOLD: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans-Bold.ttf");

pub(crate) const TITLE_PX: f64 = 42.0;
pub(crate) const SUBTITLE_PX: f64 = 28.0;
pub(crate) const LABEL_PX: f64 = 30.0;
pub(crate) const TICK_PX: f64 = 26.0;
pub(crate) const LEGEND_PX: f64 = 26.0;

/// Registers the bundled fonts with plotters (once).
fn fonts() -> Result<(), FigureError> {
    static DONE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    let ok = *DONE.get_or_init(|| {
        plotters::style::register_font(FONT, FontStyle::Normal, DEJAVU_SANS).is_ok()
            && plotters::style::register_font(FONT, FontStyle::Bold, DEJAVU_SANS_BOLD).is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(FigureError::Draw(
            "the bundled font could not be read".into(),
        ))
    }
}

/// A figure could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum FigureError {
    /// Nothing to draw (no series, no samples, no cells).
    #[error("nothing to draw: {0}")]
    Empty(String),
    #[error("drawing failed: {0}")]
    Draw(String),
    #[error("{file}: cannot write file: {err}")]
    Write { file: PathBuf, err: std::io::Error },
}

pub(crate) fn draw_err<E: std::fmt::Display>(e: E) -> FigureError {
    FigureError::Draw(e.to_string())
}

/// A drawn figure: its SVG text and its pixels, ready to write.
#[derive(Debug, Clone)]
pub struct Figure {
    title: String,
    svg: String,
    rgb: Vec<u8>,
    width: u32,
    height: u32,
}

impl Figure {
    pub fn title(&self) -> &str {
        &self.title
    }

    /// Size in pixels (PNG) and SVG user units.
    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The SVG document (text as `<text>` elements, a `<title>`, a view box), for files and
    /// for inlining into HTML.
    pub fn svg(&self) -> &str {
        &self.svg
    }

    /// The PNG file's bytes.
    pub fn png(&self) -> Result<Vec<u8>, FigureError> {
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, self.width, self.height);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        let mut w = enc.write_header().map_err(draw_err)?;
        w.write_image_data(&self.rgb).map_err(draw_err)?;
        w.finish().map_err(draw_err)?;
        Ok(out)
    }

    /// Writes `dir/stem.png` and `dir/stem.svg`, each atomically (a temporary file renamed),
    /// creating `dir` if needed. Returns the two paths.
    pub fn write(&self, dir: &Path, stem: &str) -> Result<Vec<PathBuf>, FigureError> {
        std::fs::create_dir_all(dir).map_err(|err| FigureError::Write {
            file: dir.to_path_buf(),
            err,
        })?;
        let png_path = dir.join(format!("{stem}.png"));
        let svg_path = dir.join(format!("{stem}.svg"));
        let png = self.png()?;
        for (path, bytes) in [(&png_path, &png[..]), (&svg_path, self.svg.as_bytes())] {
            crate::atomic::write_atomic(path, bytes).map_err(|err| FigureError::Write {
                file: path.clone(),
                err,
            })?;
        }
        Ok(vec![png_path, svg_path])
    }
}

impl crate::ScenarioError {
    /// A figure that could not be written into `out`, as a write error naming the file (the
    /// figure's own path when writing failed, else `out`).
    pub fn figure(out: &Path, e: FigureError) -> crate::ScenarioError {
        match e {
            FigureError::Write { file, err } => crate::ScenarioError::Write { file, err },
            other => crate::ScenarioError::Write {
                file: out.to_path_buf(),
                err: std::io::Error::other(other.to_string()),
            },
        }
    }
}

/// Something that draws itself on any plotters backend.
pub(crate) trait Draw {
    fn title(&self) -> &str;
    /// Height in pixels for [`WIDTH`].
    fn height(&self) -> u32;
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), FigureError>;
}

/// Draws `d` on the SVG and the bitmap backends.
pub(crate) fn render(d: &impl Draw) -> Result<Figure, FigureError> {
    fonts()?;
    let (w, h) = (WIDTH, d.height().clamp(200, 6000));
    let mut svg = String::new();
    {
        let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(draw_err)?;
        d.draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    // A title element (shown by browsers as a tooltip, read by screen readers).
    if let Some(end) = svg.find('>') {
        let title = format!("\n<title>{}</title>", escape(d.title()));
        svg.insert_str(end + 1, &title);
    }
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        d.draw(&root)?;
        root.present().map_err(draw_err)?;
    }
    Ok(Figure {
        title: d.title().to_string(),
        svg,
        rgb,
        width: w,
        height: h,
    })
}

/// Escapes text for XML and HTML.
pub fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '&' => out.push_str("&amp;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

pub(crate) fn rgb(c: Rgb) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

pub(crate) fn font(px: f64) -> TextStyle<'static> {
    (FONT, px).into_font().color(&BLACK)
}

pub(crate) fn bold(px: f64) -> TextStyle<'static> {
    (FONT, px, FontStyle::Bold).into_font().color(&BLACK)
}

/// Width in pixels of `text` in the figure font at `px`.
pub(crate) fn text_width(text: &str, px: f64) -> u32 {
    (FONT, px)
        .into_font()
        .box_size(text)
        .map(|(w, _)| w)
        .unwrap_or((text.chars().count() as f64 * px * 0.6) as u32)
}

/// Splits `text` into lines no wider than `width` pixels at `px`.
pub(crate) fn wrap(text: &str, px: f64, width: u32) -> Vec<String> {
    let mut lines = Vec::new();
    for para in text.split('\n') {
        let mut line = String::new();
        for word in para.split(' ') {
            let candidate = if line.is_empty() {
                word.to_string()
            } else {
                format!("{line} {word}")
            };
            if !line.is_empty() && text_width(&candidate, px) > width {
                lines.push(std::mem::take(&mut line));
                line = word.to_string();
            } else {
                line = candidate;
            }
        }
        lines.push(line);
    }
    lines
}

/// Height of the title block for `title` and `subtitle`.
pub(crate) fn header_height(title: &str, subtitle: &str) -> u32 {
    let t = wrap(title, TITLE_PX, WIDTH - 80).len() as u32;
    let s = if subtitle.is_empty() {
        0
    } else {
        wrap(subtitle, SUBTITLE_PX, WIDTH - 80).len() as u32
    };
    24 + t * 52 + s * 36 + 12
}

/// Draws the title block at the top of `root`; returns the area below it.
pub(crate) fn draw_header<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    subtitle: &str,
) -> Result<DrawingArea<DB, Shift>, FigureError> {
    let h = header_height(title, subtitle);
    let (top, rest) = root.split_vertically(h);
    let mut y = 24;
    for line in wrap(title, TITLE_PX, WIDTH - 80) {
        top.draw(&Text::new(line, (40, y), bold(TITLE_PX)))
            .map_err(draw_err)?;
        y += 52;
    }
    if !subtitle.is_empty() {
        for line in wrap(subtitle, SUBTITLE_PX, WIDTH - 80) {
            top.draw(&Text::new(
                line,
                (40, y),
                font(SUBTITLE_PX).color(&RGBColor(60, 60, 60)),
            ))
            .map_err(draw_err)?;
            y += 36;
        }
    }
    Ok(rest)
}

/// How a legend entry is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Swatch {
    Line(Rgb),
    Dashed(Rgb),
    /// A filled box (areas, bars, cells).
    Fill(Rgb),
    /// A translucent band behind a line (an interval).
    Band(Rgb),
    Dot(Rgb),
    /// An ellipse outline.
    Ring(Rgb),
}

const SWATCH_W: u32 = 56;
const LEGEND_ROW: u32 = 42;

fn legend_rows(entries: &[(String, Swatch)], width: u32) -> Vec<Vec<usize>> {
    let mut rows: Vec<Vec<usize>> = Vec::new();
    let mut x = 0;
    for (i, (label, _)) in entries.iter().enumerate() {
        let w = SWATCH_W + 12 + text_width(label, LEGEND_PX) + 36;
        if rows.is_empty() || (x + w > width && x > 0) {
            rows.push(Vec::new());
            x = 0;
        }
        rows.last_mut().expect("a row").push(i);
        x += w;
    }
    rows
}

/// Height of a legend strip holding `entries` (0 when there are none).
pub(crate) fn legend_height(entries: &[(String, Swatch)]) -> u32 {
    if entries.is_empty() {
        0
    } else {
        legend_rows(entries, WIDTH - 80).len() as u32 * LEGEND_ROW + 16
    }
}

/// Draws a legend strip (entries left to right, wrapping) into `area`.
pub(crate) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, Swatch)],
) -> Result<(), FigureError> {
    let rows = legend_rows(entries, WIDTH - 80);
    for (r, row) in rows.iter().enumerate() {
        let mut x = 40i32;
        let y = 8 + r as i32 * LEGEND_ROW as i32 + LEGEND_ROW as i32 / 2;
        for &i in row {
            let (label, swatch) = &entries[i];
            let (x0, x1) = (x, x + SWATCH_W as i32);
            let e = match *swatch {
                Swatch::Line(c) => area.draw(&PathElement::new(
                    vec![(x0, y), (x1, y)],
                    rgb(c).stroke_width(5),
                )),
                Swatch::Dashed(c) => {
                    let mut res = Ok(());
                    for k in 0..4 {
                        let a = x0 + k * 15;
                        res = res.and(area.draw(&PathElement::new(
                            vec![(a, y), (a + 9, y)],
                            rgb(c).stroke_width(5),
                        )));
                    }
                    res
                }
                Swatch::Fill(c) => area.draw(&Rectangle::new(
                    [(x0, y - 12), (x1, y + 12)],
                    rgb(c).filled(),
                )),
                Swatch::Band(c) => area
                    .draw(&Rectangle::new(
                        [(x0, y - 12), (x1, y + 12)],
                        rgb(c).mix(0.25).filled(),
                    ))
                    .and(area.draw(&PathElement::new(
                        vec![(x0, y), (x1, y)],
                        rgb(c).stroke_width(4),
                    ))),
                Swatch::Dot(c) => area.draw(&Circle::new(((x0 + x1) / 2, y), 9, rgb(c).filled())),
                Swatch::Ring(c) => {
                    area.draw(&Circle::new(((x0 + x1) / 2, y), 12, rgb(c).stroke_width(3)))
                }
            };
            e.map_err(draw_err)?;
            area.draw(&Text::new(
                label.clone(),
                (x1 + 12, y),
                font(LEGEND_PX).pos(Pos::new(HPos::Left, VPos::Center)),
            ))
            .map_err(draw_err)?;
            x = x1 + 12 + text_width(label, LEGEND_PX) as i32 + 36;
        }
    }
    Ok(())
}

/// A vertical colour bar for `scale` in `area` (its ticks in the scale's units, `label`
/// beside it, rotated).
pub(crate) fn draw_colour_bar<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    scale: &ColourScale,
    label: &str,
    top: i32,
    bottom: i32,
) -> Result<(), FigureError> {
    let (x0, x1) = (20, 56);
    let h = (bottom - top).max(10);
    for s in 0..h {
        let t = 1.0 - s as f64 / (h - 1).max(1) as f64;
        area.draw(&Rectangle::new(
            [(x0, top + s), (x1, top + s + 1)],
            rgb(scale.colour_at(t)).filled(),
        ))
        .map_err(draw_err)?;
    }
    area.draw(&Rectangle::new(
        [(x0, top), (x1, bottom)],
        BLACK.stroke_width(1),
    ))
    .map_err(draw_err)?;
    for v in scale.ticks() {
        let y = top + ((1.0 - scale.t(v)) * (h - 1) as f64).round() as i32;
        area.draw(&PathElement::new(
            vec![(x1, y), (x1 + 8, y)],
            BLACK.stroke_width(2),
        ))
        .map_err(draw_err)?;
        area.draw(&Text::new(
            format_number(v),
            (x1 + 14, y),
            font(TICK_PX).pos(Pos::new(HPos::Left, VPos::Center)),
        ))
        .map_err(draw_err)?;
    }
    let (w, _) = area.dim_in_pixel();
    area.draw(&Text::new(
        label.to_string(),
        (w as i32 - 12, (top + bottom) / 2),
        font(LABEL_PX)
            .transform(FontTransform::Rotate270)
            .pos(Pos::new(HPos::Center, VPos::Bottom)),
    ))
    .map_err(draw_err)?;
    Ok(())
}

#[cfg(test)]
mod tests;

/// `s` cut to `n` characters with an ellipsis.
pub(crate) fn clip(s: &str, n: usize) -> String {
    if s.chars().count() <= n {
        s.to_string()
    } else {
        let cut: String = s.chars().take(n - 1).collect();
        format!("{cut}…")
    }
}
