//! Line charts (with interval bands and labelled thresholds), stacked panels of them,
//! overlaid histograms and heat maps.

use super::colour::{line_colour, ColourScale, Rgb};
use super::{
    bold, draw_colour_bar, draw_err, draw_header, draw_legend, font, format_number, header_height,
    legend_height, render, rgb, text_width, Draw, Figure, FigureError, Swatch, LABEL_PX, LEGEND_PX,
    TICK_PX, WIDTH,
};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// One line of a [`LineChart`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    /// An interval around the line: (x, low, high), drawn as a translucent band.
    pub band: Vec<(f64, f64, f64)>,
    /// Default: the series' place in the Okabe–Ito palette.
    pub colour: Option<Rgb>,
    pub dashed: bool,
}

impl Series {
    pub fn new(label: impl Into<String>, points: Vec<(f64, f64)>) -> Series {
        Series {
            label: label.into(),
            points,
            ..Series::default()
        }
    }

    /// Adds an interval band: (x, low, high) per point.
    pub fn with_band(mut self, band: Vec<(f64, f64, f64)>) -> Series {
        self.band = band;
        self
    }

    pub fn colour(mut self, c: Rgb) -> Series {
        self.colour = Some(c);
        self
    }

    pub fn dashed(mut self) -> Series {
        self.dashed = true;
        self
    }
}

/// A horizontal reference line with its label written on it.
#[derive(Debug, Clone, PartialEq)]
pub struct Threshold {
    pub value: f64,
    pub label: String,
}

impl Threshold {
    pub fn new(value: f64, label: impl Into<String>) -> Threshold {
        Threshold {
            value,
            label: label.into(),
        }
    }
}

/// A chart of lines against a numeric x.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LineChart {
    pub title: String,
    pub subtitle: String,
    /// With the unit, e.g. "corridor width (m)".
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
    pub thresholds: Vec<Threshold>,
    /// Fixed y range; default: the data's, padded.
    pub y_range: Option<(f64, f64)>,
    /// Start the y axis at 0 (rates, errors).
    pub y_from_zero: bool,
}

/// Draws one chart as a figure with a legend below it.
pub fn line_chart(c: &LineChart) -> Result<Figure, FigureError> {
    check_lines(c)?;
    render(&Panels {
        title: c.title.clone(),
        subtitle: c.subtitle.clone(),
        panels: vec![c.clone()],
        single: true,
    })
}

/// Several charts stacked vertically under one title (each panel's `title` names it; their
/// subtitles are ignored).
pub fn line_panels(
    title: &str,
    subtitle: &str,
    panels: &[LineChart],
) -> Result<Figure, FigureError> {
    if panels.is_empty() {
        return Err(FigureError::Empty(format!("{title}: no panels")));
    }
    for p in panels {
        check_lines(p)?;
    }
    render(&Panels {
        title: title.into(),
        subtitle: subtitle.into(),
        panels: panels.to_vec(),
        single: false,
    })
}

fn check_lines(c: &LineChart) -> Result<(), FigureError> {
    let any = c
        .series
        .iter()
        .any(|s| s.points.iter().any(|(x, y)| x.is_finite() && y.is_finite()));
    if any {
        Ok(())
    } else {
        Err(FigureError::Empty(format!("{}: no finite points", c.title)))
    }
}

struct Panels {
    title: String,
    subtitle: String,
    panels: Vec<LineChart>,
    single: bool,
}

const PANEL_H: u32 = 900;
const STACKED_H: u32 = 620;

fn entries(c: &LineChart) -> Vec<(String, Swatch)> {
    let mut out = Vec::new();
    for (i, s) in c.series.iter().enumerate() {
        let col = s.colour.unwrap_or(line_colour(i));
        let sw = if !s.band.is_empty() {
            Swatch::Band(col)
        } else if s.dashed {
            Swatch::Dashed(col)
        } else {
            Swatch::Line(col)
        };
        out.push((s.label.clone(), sw));
    }
    out
}

fn all_entries(panels: &[LineChart]) -> Vec<(String, Swatch)> {
    let mut out: Vec<(String, Swatch)> = Vec::new();
    for p in panels {
        for e in entries(p) {
            if !out.iter().any(|o| o.0 == e.0) {
                out.push(e);
            }
        }
    }
    out
}

impl Draw for Panels {
    fn title(&self) -> &str {
        &self.title
    }

    fn height(&self) -> u32 {
        let per = if self.single { PANEL_H } else { STACKED_H };
        header_height(&self.title, &self.subtitle)
            + per * self.panels.len() as u32
            + legend_height(&all_entries(&self.panels))
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), FigureError> {
        let body = draw_header(root, &self.title, &self.subtitle)?;
        let entries = all_entries(&self.panels);
        let (_, h) = body.dim_in_pixel();
        let (charts, legend) = body.split_vertically(h - legend_height(&entries));
        let areas = charts.split_evenly((self.panels.len(), 1));
        for (p, area) in self.panels.iter().zip(&areas) {
            draw_lines(area, p, !self.single)?;
        }
        draw_legend(&legend, &entries)
    }
}

fn finite_range(vals: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in vals.filter(|v| v.is_finite()) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    (lo <= hi).then_some((lo, hi))
}

fn pad(lo: f64, hi: f64, frac: f64) -> (f64, f64) {
    if hi > lo {
        let d = (hi - lo) * frac;
        (lo - d, hi + d)
    } else {
        let d = lo.abs().max(1.0) * 0.1;
        (lo - d, hi + d)
    }
}

fn draw_lines<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    c: &LineChart,
    caption: bool,
) -> Result<(), FigureError> {
    let xs = c.series.iter().flat_map(|s| {
        s.points
            .iter()
            .map(|p| p.0)
            .chain(s.band.iter().map(|b| b.0))
    });
    let (x0, x1) = finite_range(xs).ok_or_else(|| FigureError::Empty(c.title.clone()))?;
    let (x0, x1) = if x1 > x0 { (x0, x1) } else { pad(x0, x1, 0.0) };
    let ys = c
        .series
        .iter()
        .flat_map(|s| {
            s.points
                .iter()
                .map(|p| p.1)
                .chain(s.band.iter().flat_map(|b| [b.1, b.2]))
        })
        .chain(c.thresholds.iter().map(|t| t.value));
    let (y0, y1) = match c.y_range {
        Some(r) => r,
        None => {
            let (lo, hi) = finite_range(ys).ok_or_else(|| FigureError::Empty(c.title.clone()))?;
            let (lo, hi) = pad(lo, hi, 0.06);
            let lo = if c.y_from_zero && lo < 0.0 && hi > 0.0 {
                0.0
            } else if c.y_from_zero {
                lo.min(0.0)
            } else {
                lo
            };
            (lo, hi)
        }
    };
    let mut b = ChartBuilder::on(area);
    b.margin(24)
        .margin_right(60)
        .x_label_area_size(110)
        .y_label_area_size(160);
    if caption {
        b.caption(&c.title, bold(LABEL_PX + 2.0));
    }
    let mut chart = b.build_cartesian_2d(x0..x1, y0..y1).map_err(draw_err)?;
    chart
        .configure_mesh()
        .x_desc(&c.x_label)
        .y_desc(&c.y_label)
        .label_style(font(TICK_PX))
        .axis_desc_style(font(LABEL_PX))
        .x_label_formatter(&|v| format_number(*v))
        .y_label_formatter(&|v| format_number(*v))
        .x_labels(8)
        .y_labels(8)
        .light_line_style(RGBColor(238, 238, 238))
        .bold_line_style(RGBColor(205, 205, 205))
        .axis_style(BLACK.stroke_width(2))
        .draw()
        .map_err(draw_err)?;
    for (i, s) in c.series.iter().enumerate() {
        let col = rgb(s.colour.unwrap_or(line_colour(i)));
        let band: Vec<(f64, f64, f64)> = s
            .band
            .iter()
            .copied()
            .filter(|b| b.0.is_finite() && b.1.is_finite() && b.2.is_finite())
            .collect();
        if band.len() >= 2 {
            let mut pts: Vec<(f64, f64)> = band.iter().map(|b| (b.0, b.1.max(y0))).collect();
            pts.extend(band.iter().rev().map(|b| (b.0, b.2.min(y1))));
            chart
                .draw_series(std::iter::once(Polygon::new(pts, col.mix(0.22).filled())))
                .map_err(draw_err)?;
        } else if let Some(b) = band.first() {
            chart
                .draw_series(std::iter::once(PathElement::new(
                    vec![(b.0, b.1), (b.0, b.2)],
                    col.mix(0.5).stroke_width(10),
                )))
                .map_err(draw_err)?;
        }
    }
    for t in &c.thresholds {
        if !(t.value.is_finite() && t.value >= y0 && t.value <= y1) {
            continue;
        }
        let grey = RGBColor(80, 80, 80);
        chart
            .draw_series(DashedLineSeries::new(
                vec![(x0, t.value), (x1, t.value)],
                16,
                10,
                grey.stroke_width(3),
            ))
            .map_err(draw_err)?;
        chart
            .draw_series(std::iter::once(Text::new(
                format!("{} ({})", t.label, format_number(t.value)),
                (x1, t.value),
                font(LEGEND_PX)
                    .color(&grey)
                    .pos(Pos::new(HPos::Right, VPos::Bottom)),
            )))
            .map_err(draw_err)?;
    }
    for (i, s) in c.series.iter().enumerate() {
        let col = rgb(s.colour.unwrap_or(line_colour(i)));
        let pts: Vec<(f64, f64)> = s
            .points
            .iter()
            .copied()
            .filter(|(x, y)| x.is_finite() && y.is_finite())
            .collect();
        if s.dashed {
            chart
                .draw_series(DashedLineSeries::new(
                    pts.clone(),
                    18,
                    10,
                    col.stroke_width(4),
                ))
                .map_err(draw_err)?;
        } else {
            chart
                .draw_series(LineSeries::new(pts.clone(), col.stroke_width(4)))
                .map_err(draw_err)?;
        }
        if pts.len() <= 40 {
            chart
                .draw_series(pts.iter().map(|p| Circle::new(*p, 7, col.filled())))
                .map_err(draw_err)?;
        }
    }
    Ok(())
}

/// One set of values for a [`Histogram`].
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Sample {
    pub label: String,
    pub values: Vec<f64>,
}

impl Sample {
    pub fn new(label: impl Into<String>, values: Vec<f64>) -> Sample {
        Sample {
            label: label.into(),
            values,
        }
    }
}

/// Overlaid, semi-transparent histograms of several samples on common bins; the y axis is
/// each sample's share (%), so samples of different sizes compare.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Histogram {
    pub title: String,
    pub subtitle: String,
    pub x_label: String,
    pub samples: Vec<Sample>,
    /// Number of bins (default 30 when 0).
    pub bins: usize,
}

pub fn histogram(h: &Histogram) -> Result<Figure, FigureError> {
    let (lo, hi) = finite_range(h.samples.iter().flat_map(|s| s.values.iter().copied()))
        .ok_or_else(|| FigureError::Empty(format!("{}: no finite values", h.title)))?;
    let (lo, hi) = if hi > lo { (lo, hi) } else { pad(lo, hi, 0.0) };
    render(&HistogramDraw { h, lo, hi })
}

struct HistogramDraw<'a> {
    h: &'a Histogram,
    lo: f64,
    hi: f64,
}

impl HistogramDraw<'_> {
    fn entries(&self) -> Vec<(String, Swatch)> {
        self.h
            .samples
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let n = s.values.iter().filter(|v| v.is_finite()).count();
                (
                    format!("{} (n = {n})", s.label),
                    Swatch::Fill(line_colour(i)),
                )
            })
            .collect()
    }
}

impl Draw for HistogramDraw<'_> {
    fn title(&self) -> &str {
        &self.h.title
    }

    fn height(&self) -> u32 {
        header_height(&self.h.title, &self.h.subtitle) + PANEL_H + legend_height(&self.entries())
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), FigureError> {
        let h = self.h;
        let bins = if h.bins == 0 { 30 } else { h.bins };
        let width = (self.hi - self.lo) / bins as f64;
        let shares: Vec<Vec<f64>> = h
            .samples
            .iter()
            .map(|s| {
                let mut counts = vec![0usize; bins];
                let mut n = 0;
                for v in s.values.iter().filter(|v| v.is_finite()) {
                    let k = (((v - self.lo) / width) as usize).min(bins - 1);
                    counts[k] += 1;
                    n += 1;
                }
                counts
                    .iter()
                    .map(|c| 100.0 * *c as f64 / n.max(1) as f64)
                    .collect()
            })
            .collect();
        let top = shares
            .iter()
            .flatten()
            .fold(0.0f64, |m, v| m.max(*v))
            .max(1.0)
            * 1.08;
        let body = draw_header(root, &h.title, &h.subtitle)?;
        let entries = self.entries();
        let (_, bh) = body.dim_in_pixel();
        let (plot, legend) = body.split_vertically(bh - legend_height(&entries));
        let mut chart = ChartBuilder::on(&plot)
            .margin(24)
            .margin_right(60)
            .x_label_area_size(110)
            .y_label_area_size(160)
            .build_cartesian_2d(self.lo..self.hi, 0.0..top)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc(&h.x_label)
            .y_desc("share of the sample (%)")
            .label_style(font(TICK_PX))
            .axis_desc_style(font(LABEL_PX))
            .x_label_formatter(&|v| format_number(*v))
            .y_label_formatter(&|v| format_number(*v))
            .light_line_style(RGBColor(238, 238, 238))
            .bold_line_style(RGBColor(205, 205, 205))
            .axis_style(BLACK.stroke_width(2))
            .draw()
            .map_err(draw_err)?;
        for (i, share) in shares.iter().enumerate() {
            let col = rgb(line_colour(i));
            let bars = share
                .iter()
                .enumerate()
                .filter(|(_, p)| **p > 0.0)
                .map(|(k, p)| {
                    let a = self.lo + k as f64 * width;
                    [(a, 0.0), (a + width, *p)]
                });
            chart
                .draw_series(
                    bars.clone()
                        .map(|r| Rectangle::new(r, col.mix(0.35).filled())),
                )
                .map_err(draw_err)?;
            chart
                .draw_series(bars.map(|r| Rectangle::new(r, col.stroke_width(2))))
                .map_err(draw_err)?;
        }
        draw_legend(&legend, &entries)
    }
}

/// Cells on a grid of two labelled axes, coloured by value, the value written in each.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Heatmap {
    pub title: String,
    pub subtitle: String,
    pub x_label: String,
    /// Empty for a one-row strip.
    pub y_label: String,
    pub x_values: Vec<String>,
    /// One empty label for a strip.
    pub y_values: Vec<String>,
    /// `values[y * x_values.len() + x]`; `None`: no data (hatched grey).
    pub values: Vec<Option<f64>>,
    /// The colour bar's label, with the unit.
    pub colour_label: String,
    /// Default: viridis over the values, logarithmic when all are positive.
    pub scale: Option<ColourScale>,
}

pub fn heatmap(h: &Heatmap) -> Result<Figure, FigureError> {
    let (nx, ny) = (h.x_values.len(), h.y_values.len());
    if nx == 0 || ny == 0 || h.values.len() != nx * ny {
        return Err(FigureError::Empty(format!(
            "{}: {} values for {nx} × {ny} cells",
            h.title,
            h.values.len()
        )));
    }
    let scale = h
        .scale
        .unwrap_or_else(|| ColourScale::auto(h.values.iter().flatten().copied(), true));
    render(&HeatmapDraw { h, scale })
}

struct HeatmapDraw<'a> {
    h: &'a Heatmap,
    scale: ColourScale,
}

const BAR_W: u32 = 230;

impl Draw for HeatmapDraw<'_> {
    fn title(&self) -> &str {
        &self.h.title
    }

    fn height(&self) -> u32 {
        let ny = self.h.y_values.len() as u32;
        let plot_w = WIDTH - BAR_W - 300;
        let cell = (plot_w / self.h.x_values.len() as u32).clamp(40, 200);
        let widest = self
            .h
            .x_values
            .iter()
            .map(|v| text_width(&super::clip(v, 24), TICK_PX))
            .max()
            .unwrap_or(0);
        let x_area = if widest + 8 > cell { widest + 110 } else { 110 };
        header_height(&self.h.title, &self.h.subtitle) + (cell * ny).clamp(200, 1800) + x_area + 60
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), FigureError> {
        let h = self.h;
        let (nx, ny) = (h.x_values.len(), h.y_values.len());
        let body = draw_header(root, &h.title, &h.subtitle)?;
        let (bw, bh) = body.dim_in_pixel();
        let (plot, bar) = body.split_horizontally(bw - BAR_W);
        let label_w = h
            .y_values
            .iter()
            .map(|v| text_width(v, TICK_PX))
            .max()
            .unwrap_or(0);
        let y_area = if h.y_label.is_empty() {
            label_w + 30
        } else {
            label_w + 80
        };
        let widest = h
            .x_values
            .iter()
            .map(|v| text_width(&super::clip(v, 24), TICK_PX) as i32)
            .max()
            .unwrap_or(0);
        let approx_cell = (bw - BAR_W - y_area - 60) as i32 / nx as i32;
        let rotate = widest + 8 > approx_cell;
        let x_area = if rotate { widest as u32 + 110 } else { 110 };
        let mut chart = ChartBuilder::on(&plot)
            .margin(24)
            .margin_right(30)
            .x_label_area_size(x_area)
            .y_label_area_size(y_area.max(40))
            .build_cartesian_2d(0.0..nx as f64, 0.0..ny as f64)
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(0)
            .y_labels(0)
            .x_desc(&h.x_label)
            .y_desc(&h.y_label)
            .axis_desc_style(font(LABEL_PX))
            .axis_style(BLACK.stroke_width(2))
            .draw()
            .map_err(draw_err)?;
        let cell_px = chart.backend_coord(&(1.0, 0.0)).0 - chart.backend_coord(&(0.0, 0.0)).0;
        let cell_py = chart.backend_coord(&(0.0, 0.0)).1 - chart.backend_coord(&(0.0, 1.0)).1;
        for j in 0..ny {
            for i in 0..nx {
                let r = [(i as f64, j as f64), (i as f64 + 1.0, j as f64 + 1.0)];
                match h.values[j * nx + i] {
                    Some(v) if v.is_finite() => {
                        let c = self.scale.colour(v);
                        chart
                            .draw_series(std::iter::once(Rectangle::new(r, rgb(c).filled())))
                            .map_err(draw_err)?;
                        let text = format_number(v);
                        let size = (TICK_PX).min(cell_py as f64 * 0.45);
                        if text_width(&text, size) as i32 + 6 < cell_px && size >= 12.0 {
                            let tc = super::colour::text_on(c);
                            chart
                                .draw_series(std::iter::once(Text::new(
                                    text,
                                    (i as f64 + 0.5, j as f64 + 0.5),
                                    font(size)
                                        .color(&rgb(tc))
                                        .pos(Pos::new(HPos::Center, VPos::Center)),
                                )))
                                .map_err(draw_err)?;
                        }
                    }
                    _ => {
                        chart
                            .draw_series(std::iter::once(Rectangle::new(
                                r,
                                RGBColor(225, 225, 225).filled(),
                            )))
                            .map_err(draw_err)?;
                        chart
                            .draw_series(std::iter::once(Text::new(
                                "no data",
                                (i as f64 + 0.5, j as f64 + 0.5),
                                font(LEGEND_PX * 0.8).pos(Pos::new(HPos::Center, VPos::Center)),
                            )))
                            .map_err(draw_err)?;
                    }
                }
                chart
                    .draw_series(std::iter::once(Rectangle::new(r, WHITE.stroke_width(2))))
                    .map_err(draw_err)?;
            }
        }
        // Tick labels at the cells' centres, in pixels of the whole figure.
        for (i, v) in h.x_values.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(i as f64 + 0.5, 0.0));
            let style = if rotate {
                font(TICK_PX)
                    .transform(FontTransform::Rotate270)
                    .pos(Pos::new(HPos::Right, VPos::Center))
            } else {
                font(TICK_PX).pos(Pos::new(HPos::Center, VPos::Top))
            };
            root.draw(&Text::new(super::clip(v, 24), (x, y + 10), style))
                .map_err(draw_err)?;
        }
        for (j, v) in h.y_values.iter().enumerate() {
            let (x, y) = chart.backend_coord(&(0.0, j as f64 + 0.5));
            root.draw(&Text::new(
                super::clip(v, 24),
                (x - 10, y),
                font(TICK_PX).pos(Pos::new(HPos::Right, VPos::Center)),
            ))
            .map_err(draw_err)?;
        }
        let top =
            chart.backend_coord(&(0.0, ny as f64)).1 - header_height(&h.title, &h.subtitle) as i32;
        let bottom = (chart.backend_coord(&(0.0, 0.0)).1
            - header_height(&h.title, &h.subtitle) as i32)
            .min(bh as i32 - 10);
        draw_colour_bar(&bar, &self.scale, &h.colour_label, top.max(30), bottom)
    }
}
