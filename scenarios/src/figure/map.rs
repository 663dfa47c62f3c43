//! Maps in metres: a world (walls; glass dashed cyan) or an occupancy grid underneath,
//! per-location cells coloured by a value with a colour bar, paths, a path coloured by a
//! value, ellipses and markers; axes in metres, equal scale on both, a scale bar, a legend.

use super::colour::{viridis, ColourScale, Rgb, GLASS, WALL};
use super::{
    draw_colour_bar, draw_err, draw_header, draw_legend, font, format_number, header_height,
    legend_height, nice_step, render, rgb, Draw, Figure, FigureError, Swatch, LABEL_PX, TICK_PX,
    WIDTH,
};
use atrium_worlds::geometry::wall_corners;
use atrium_worlds::{Cell, LaserBehaviour, OccupancyGrid, World};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// What lies under the map's drawings.
#[derive(Debug, Clone, Copy, Default)]
pub enum MapBase<'a> {
    #[default]
    Empty,
    /// Walls (glass dashed cyan) and pillars.
    World(&'a World),
    /// Occupied cells grey, unknown cells light grey.
    Grid(&'a OccupancyGrid),
}

/// Square cells coloured by a value (e.g. mean position error per location).
#[derive(Debug, Clone, PartialEq)]
pub struct MapCells {
    pub origin: [f64; 2],
    pub resolution: f64,
    pub width: usize,
    pub height: usize,
    /// `values[j * width + i]`, cell (i, j) covering x ∈ [origin.x + i·res, +res).
    pub values: Vec<Option<f64>>,
    /// The colour bar's label, with the unit: "mean position error (m)".
    pub label: String,
    pub scale: ColourScale,
    /// When not empty, the values are indices into this list of (name, colour) — e.g. the
    /// best localizer per cell — shown in the legend instead of a colour bar.
    pub categories: Vec<(String, Rgb)>,
}

impl MapCells {
    /// Cells naming a category each (`values` hold indices into `categories`).
    pub fn categorical(
        origin: [f64; 2],
        resolution: f64,
        (width, height): (usize, usize),
        values: Vec<Option<usize>>,
        categories: Vec<(String, Rgb)>,
    ) -> MapCells {
        MapCells {
            origin,
            resolution,
            width,
            height,
            values: values.into_iter().map(|v| v.map(|v| v as f64)).collect(),
            label: String::new(),
            scale: ColourScale::auto([0.0, 1.0], false),
            categories,
        }
    }

    /// Cells with a viridis scale over their values, logarithmic when `log` (and all > 0).
    pub fn new(
        origin: [f64; 2],
        resolution: f64,
        (width, height): (usize, usize),
        values: Vec<Option<f64>>,
        label: impl Into<String>,
        log: bool,
    ) -> MapCells {
        let scale = ColourScale::auto(values.iter().flatten().copied(), log);
        MapCells {
            origin,
            resolution,
            width,
            height,
            values,
            label: label.into(),
            scale,
            categories: Vec::new(),
        }
    }
}

/// A path in one colour.
#[derive(Debug, Clone, PartialEq)]
pub struct MapPath {
    pub label: String,
    pub points: Vec<[f64; 2]>,
    pub colour: Rgb,
    pub dashed: bool,
    /// Line width, pixels (default 4).
    pub width: u32,
}

impl MapPath {
    pub fn new(label: impl Into<String>, points: Vec<[f64; 2]>) -> MapPath {
        MapPath {
            label: label.into(),
            points,
            colour: [0, 0, 0],
            dashed: false,
            width: 4,
        }
    }

    pub fn colour(mut self, c: Rgb) -> MapPath {
        self.colour = c;
        self
    }

    pub fn dashed(mut self) -> MapPath {
        self.dashed = true;
        self
    }

    pub fn width(mut self, px: u32) -> MapPath {
        self.width = px;
        self
    }
}

/// A path coloured point by point by a value (e.g. a localizer's path by its error), with
/// the figure's colour bar.
#[derive(Debug, Clone, PartialEq)]
pub struct ValuePath {
    pub label: String,
    pub points: Vec<[f64; 2]>,
    /// One per point.
    pub values: Vec<f64>,
    /// The colour bar's label, with the unit (when the figure has no [`MapCells`]).
    pub colour_label: String,
    pub scale: ColourScale,
}

/// What a [`MapShape`] draws.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ShapeKind {
    /// Outline of an ellipse: semi-axes (m) and the first axis' angle (rad).
    Ellipse {
        centre: [f64; 2],
        semi_axes: (f64, f64),
        angle: f64,
    },
    /// A dot `radius_px` pixels across.
    Dot { centre: [f64; 2], radius_px: u32 },
    /// A line segment (a heading arrow's shaft).
    Segment { from: [f64; 2], to: [f64; 2] },
}

/// A shape; shapes with a label appear in the legend (once per label).
#[derive(Debug, Clone, PartialEq)]
pub struct MapShape {
    pub kind: ShapeKind,
    pub colour: Rgb,
    pub label: Option<String>,
}

impl MapShape {
    pub fn ellipse(centre: [f64; 2], semi_axes: (f64, f64), angle: f64, colour: Rgb) -> MapShape {
        MapShape {
            kind: ShapeKind::Ellipse {
                centre,
                semi_axes,
                angle,
            },
            colour,
            label: None,
        }
    }

    pub fn dot(centre: [f64; 2], radius_px: u32, colour: Rgb) -> MapShape {
        MapShape {
            kind: ShapeKind::Dot { centre, radius_px },
            colour,
            label: None,
        }
    }

    pub fn segment(from: [f64; 2], to: [f64; 2], colour: Rgb) -> MapShape {
        MapShape {
            kind: ShapeKind::Segment { from, to },
            colour,
            label: None,
        }
    }

    pub fn label(mut self, l: impl Into<String>) -> MapShape {
        self.label = Some(l.into());
        self
    }
}

/// An extra legend line (besides those of the base, paths and labelled shapes).
#[derive(Debug, Clone, PartialEq)]
pub struct LegendEntry {
    pub label: String,
    pub swatch: super::Swatch,
}

/// A map figure. Drawn in this order: base, cells, paths, value path, shapes.
#[derive(Debug, Clone, Default)]
pub struct MapFigure<'a> {
    pub title: String,
    pub subtitle: String,
    pub base: MapBase<'a>,
    pub cells: Option<MapCells>,
    pub paths: Vec<MapPath>,
    pub value_path: Option<ValuePath>,
    pub shapes: Vec<MapShape>,
    pub legend: Vec<LegendEntry>,
    /// The area shown, (min, max) in metres; default: everything drawn, with a margin.
    pub view: Option<([f64; 2], [f64; 2])>,
}

pub fn map_figure(m: &MapFigure<'_>) -> Result<Figure, FigureError> {
    let (lo, hi) = match m.view {
        Some(v) => v,
        None => {
            extent(m).ok_or_else(|| FigureError::Empty(format!("{}: nothing to draw", m.title)))?
        }
    };
    if !(hi[0] > lo[0] && hi[1] > lo[1]) {
        return Err(FigureError::Empty(format!("{}: empty view", m.title)));
    }
    let layout = Layout::new(m, lo, hi);
    render(&MapDraw { m, layout })
}

fn is_glass(world: &World, material: &str) -> bool {
    world
        .materials
        .iter()
        .any(|m| m.name == material && matches!(m.laser, LaserBehaviour::Glass { .. }))
}

fn extent(m: &MapFigure<'_>) -> Option<([f64; 2], [f64; 2])> {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    let mut grow = |p: [f64; 2]| {
        if p[0].is_finite() && p[1].is_finite() {
            for k in 0..2 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
    };
    match m.base {
        MapBase::Empty => {}
        MapBase::World(w) => {
            if !w.walls.is_empty() || !w.pillars.is_empty() {
                let (a, b) = w.bounds();
                grow(a);
                grow(b);
            }
        }
        MapBase::Grid(g) => {
            grow(g.origin);
            grow([
                g.origin[0] + g.width as f64 * g.resolution,
                g.origin[1] + g.height as f64 * g.resolution,
            ]);
        }
    }
    if let Some(c) = &m.cells {
        for j in 0..c.height {
            for i in 0..c.width {
                if c.values.get(j * c.width + i).copied().flatten().is_some() {
                    grow([
                        c.origin[0] + i as f64 * c.resolution,
                        c.origin[1] + j as f64 * c.resolution,
                    ]);
                    grow([
                        c.origin[0] + (i + 1) as f64 * c.resolution,
                        c.origin[1] + (j + 1) as f64 * c.resolution,
                    ]);
                }
            }
        }
    }
    for p in &m.paths {
        p.points.iter().for_each(|q| grow(*q));
    }
    if let Some(v) = &m.value_path {
        v.points.iter().for_each(|q| grow(*q));
    }
    for s in &m.shapes {
        match s.kind {
            ShapeKind::Ellipse {
                centre, semi_axes, ..
            } => {
                let r = semi_axes.0.abs().max(semi_axes.1.abs());
                grow([centre[0] - r, centre[1] - r]);
                grow([centre[0] + r, centre[1] + r]);
            }
            ShapeKind::Dot { centre, .. } => grow(centre),
            ShapeKind::Segment { from, to } => {
                grow(from);
                grow(to);
            }
        }
    }
    if lo[0] > hi[0] {
        return None;
    }
    let margin = 0.03 * (hi[0] - lo[0]).max(hi[1] - lo[1]).max(1.0);
    Some((
        [lo[0] - margin, lo[1] - margin],
        [hi[0] + margin, hi[1] + margin],
    ))
}

const LEFT: u32 = 150;
const BOTTOM: u32 = 110;
const MARGIN: u32 = 24;
const BAR_W: u32 = 230;

/// The view widened so that one metre is as long on both axes, and the figure's height.
struct Layout {
    lo: [f64; 2],
    hi: [f64; 2],
    plot_h: u32,
    bar: bool,
}

impl Layout {
    fn new(m: &MapFigure<'_>, mut lo: [f64; 2], mut hi: [f64; 2]) -> Layout {
        let bar =
            m.cells.as_ref().is_some_and(|c| c.categories.is_empty()) || m.value_path.is_some();
        let plot_w = (WIDTH - LEFT - 2 * MARGIN - if bar { BAR_W } else { 30 }) as f64;
        let (dx, dy) = (hi[0] - lo[0], hi[1] - lo[1]);
        let want_h = plot_w * dy / dx;
        let plot_h = want_h.clamp(420.0, 1700.0);
        // Widen the shorter side about its middle so the scale stays equal.
        let per_m = (plot_w / dx).min(plot_h / dy);
        let (nx, ny) = (plot_w / per_m, plot_h / per_m);
        let (cx, cy) = (0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]));
        lo = [cx - nx / 2.0, cy - ny / 2.0];
        hi = [cx + nx / 2.0, cy + ny / 2.0];
        Layout {
            lo,
            hi,
            plot_h: plot_h.round() as u32,
            bar,
        }
    }

    fn px_per_m(&self) -> f64 {
        self.plot_h as f64 / (self.hi[1] - self.lo[1])
    }
}

struct MapDraw<'a, 'b> {
    m: &'a MapFigure<'b>,
    layout: Layout,
}

impl MapDraw<'_, '_> {
    fn entries(&self) -> Vec<(String, Swatch)> {
        let m = self.m;
        let mut out: Vec<(String, Swatch)> = Vec::new();
        match m.base {
            MapBase::Empty => {}
            MapBase::World(w) => {
                out.push(("wall".into(), Swatch::Fill(WALL)));
                if w.walls.iter().any(|wall| is_glass(w, &wall.material)) {
                    out.push(("glass wall".into(), Swatch::Dashed(GLASS)));
                }
            }
            MapBase::Grid(_) => out.push(("occupied (map)".into(), Swatch::Fill(WALL))),
        }
        if let Some(c) = &m.cells {
            for (name, colour) in &c.categories {
                out.push((name.clone(), Swatch::Fill(*colour)));
            }
        }
        for p in &m.paths {
            let sw = if p.dashed {
                Swatch::Dashed(p.colour)
            } else {
                Swatch::Line(p.colour)
            };
            out.push((p.label.clone(), sw));
        }
        if let Some(v) = &m.value_path {
            out.push((v.label.clone(), Swatch::Line(viridis(0.5))));
        }
        for s in &m.shapes {
            if let Some(l) = &s.label {
                if !out.iter().any(|(o, _)| o == l) {
                    let sw = match s.kind {
                        ShapeKind::Ellipse { .. } => Swatch::Ring(s.colour),
                        ShapeKind::Dot { .. } => Swatch::Dot(s.colour),
                        ShapeKind::Segment { .. } => Swatch::Line(s.colour),
                    };
                    out.push((l.clone(), sw));
                }
            }
        }
        out.extend(m.legend.iter().map(|e| (e.label.clone(), e.swatch)));
        out
    }
}

type Chart<'a, DB> = ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>;

fn circle_points(c: [f64; 2], a: f64, b: f64, angle: f64, n: usize) -> Vec<(f64, f64)> {
    let (s, co) = angle.sin_cos();
    (0..=n)
        .map(|k| {
            let t = k as f64 * std::f64::consts::TAU / n as f64;
            let (x, y) = (a * t.cos(), b * t.sin());
            (c[0] + co * x - s * y, c[1] + s * x + co * y)
        })
        .collect()
}

fn draw_world<DB: DrawingBackend>(chart: &mut Chart<'_, DB>, w: &World) -> Result<(), FigureError> {
    for wall in &w.walls {
        let pts: Vec<(f64, f64)> = wall_corners(wall.a, wall.b, wall.thickness)
            .iter()
            .map(|p| (p[0], p[1]))
            .collect();
        if is_glass(w, &wall.material) {
            chart
                .draw_series(std::iter::once(Polygon::new(
                    pts.clone(),
                    rgb(GLASS).mix(0.3).filled(),
                )))
                .map_err(draw_err)?;
            chart
                .draw_series(DashedLineSeries::new(
                    vec![(wall.a[0], wall.a[1]), (wall.b[0], wall.b[1])],
                    14,
                    8,
                    rgb(GLASS).stroke_width(5),
                ))
                .map_err(draw_err)?;
        } else {
            chart
                .draw_series(std::iter::once(Polygon::new(pts, rgb(WALL).filled())))
                .map_err(draw_err)?;
        }
    }
    for p in &w.pillars {
        let pts = circle_points(p.center, p.radius, p.radius, 0.0, 24);
        chart
            .draw_series(std::iter::once(Polygon::new(pts, rgb(WALL).filled())))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// Cells smaller than this many pixels are drawn in blocks.
const MIN_CELL_PX: f64 = 2.0;

fn block(res: f64, px_per_m: f64) -> usize {
    (MIN_CELL_PX / (res * px_per_m)).ceil().max(1.0) as usize
}

fn draw_grid<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    g: &OccupancyGrid,
    px_per_m: f64,
) -> Result<(), FigureError> {
    let k = block(g.resolution, px_per_m);
    let (bw, bh) = (g.width.div_ceil(k), g.height.div_ceil(k));
    let state = |bi: usize, bj: usize| -> Option<Cell> {
        let mut unknown = false;
        for j in bj * k..((bj + 1) * k).min(g.height) {
            for i in bi * k..((bi + 1) * k).min(g.width) {
                match g.cells[j * g.width + i] {
                    Cell::Occupied => return Some(Cell::Occupied),
                    Cell::Unknown => unknown = true,
                    Cell::Free => {}
                }
            }
        }
        unknown.then_some(Cell::Unknown)
    };
    let size = k as f64 * g.resolution;
    let mut rects = Vec::new();
    for bj in 0..bh {
        let mut bi = 0;
        while bi < bw {
            let s = state(bi, bj);
            let start = bi;
            while bi < bw && state(bi, bj) == s {
                bi += 1;
            }
            if let Some(s) = s {
                let x0 = g.origin[0] + start as f64 * size;
                let x1 = g.origin[0] + bi as f64 * size;
                let y0 = g.origin[1] + bj as f64 * size;
                rects.push(([(x0, y0), (x1, y0 + size)], s));
            }
        }
    }
    chart
        .draw_series(rects.iter().map(|(r, s)| {
            let c = if *s == Cell::Occupied {
                rgb(WALL)
            } else {
                RGBColor(228, 228, 228)
            };
            Rectangle::new(*r, c.filled())
        }))
        .map_err(draw_err)?;
    Ok(())
}

fn draw_cells<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    c: &MapCells,
    px_per_m: f64,
) -> Result<(), FigureError> {
    let k = block(c.resolution, px_per_m);
    let size = k as f64 * c.resolution;
    let categorical = !c.categories.is_empty();
    let colour = |v: f64| -> Rgb {
        if categorical {
            c.categories
                .get(v.round().max(0.0) as usize)
                .map_or([200, 200, 200], |x| x.1)
        } else {
            c.scale.colour(v)
        }
    };
    let mut rects = Vec::new();
    for bj in 0..c.height.div_ceil(k) {
        for bi in 0..c.width.div_ceil(k) {
            let (mut sum, mut n) = (0.0, 0);
            for j in bj * k..((bj + 1) * k).min(c.height) {
                for i in bi * k..((bi + 1) * k).min(c.width) {
                    if let Some(v) = c.values.get(j * c.width + i).copied().flatten() {
                        if v.is_finite() && !(categorical && n > 0) {
                            sum += v;
                            n += 1;
                        }
                    }
                }
            }
            if n > 0 {
                let x0 = c.origin[0] + bi as f64 * size;
                let y0 = c.origin[1] + bj as f64 * size;
                rects.push(([(x0, y0), (x0 + size, y0 + size)], sum / n as f64));
            }
        }
    }
    chart
        .draw_series(
            rects
                .iter()
                .map(|(r, v)| Rectangle::new(*r, rgb(colour(*v)).filled())),
        )
        .map_err(draw_err)?;
    Ok(())
}

fn draw_value_path<DB: DrawingBackend>(
    chart: &mut Chart<'_, DB>,
    v: &ValuePath,
    scale: &ColourScale,
) -> Result<(), FigureError> {
    // Consecutive segments of one colour step (of 64) go into one polyline.
    let level = |x: f64| (scale.t(x) * 63.0).round() as u32;
    let mut runs: Vec<(u32, Vec<(f64, f64)>)> = Vec::new();
    for (k, w) in v.points.windows(2).enumerate() {
        let val = v.values.get(k + 1).copied().unwrap_or(f64::NAN);
        if !val.is_finite() {
            continue;
        }
        let l = level(val);
        let (a, b) = ((w[0][0], w[0][1]), (w[1][0], w[1][1]));
        match runs.last_mut() {
            Some((rl, pts)) if *rl == l && pts.last() == Some(&a) => pts.push(b),
            _ => runs.push((l, vec![a, b])),
        }
    }
    for (l, pts) in runs {
        let c = scale.colour_at(l as f64 / 63.0);
        chart
            .draw_series(std::iter::once(PathElement::new(
                pts,
                rgb(c).stroke_width(5),
            )))
            .map_err(draw_err)?;
    }
    Ok(())
}

/// A scale bar under the plot's lower right corner (in the axis area, so it hides nothing):
/// a round length of about an eighth of the view.
fn draw_scale_bar<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    chart: &Chart<'_, DB>,
    lo: [f64; 2],
    hi: [f64; 2],
) -> Result<(), FigureError> {
    let len = nice_step((hi[0] - lo[0]) / 8.0);
    let (x1, y) = chart.backend_coord(&(hi[0], lo[1]));
    let (x0, _) = chart.backend_coord(&(hi[0] - len, lo[1]));
    let y = y + 62;
    root.draw(&Rectangle::new([(x0, y), (x1, y + 10)], BLACK.filled()))
        .map_err(draw_err)?;
    for x in [x0, x1] {
        root.draw(&Rectangle::new(
            [(x, y - 6), (x + 2, y + 16)],
            BLACK.filled(),
        ))
        .map_err(draw_err)?;
    }
    root.draw(&Text::new(
        format!("{} m", format_number(len)),
        ((x0 + x1) / 2, y - 8),
        font(TICK_PX).pos(Pos::new(HPos::Center, VPos::Bottom)),
    ))
    .map_err(draw_err)?;
    Ok(())
}

impl Draw for MapDraw<'_, '_> {
    fn title(&self) -> &str {
        &self.m.title
    }

    fn height(&self) -> u32 {
        header_height(&self.m.title, &self.m.subtitle)
            + self.layout.plot_h
            + BOTTOM
            + 2 * MARGIN
            + legend_height(&self.entries())
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), FigureError> {
        let m = self.m;
        let (lo, hi) = (self.layout.lo, self.layout.hi);
        let body = draw_header(root, &m.title, &m.subtitle)?;
        let entries = self.entries();
        let (bw, bh) = body.dim_in_pixel();
        let (main, legend) = body.split_vertically(bh - legend_height(&entries));
        let (plot, bar) = if self.layout.bar {
            main.split_horizontally(bw - BAR_W)
        } else {
            main.split_horizontally(bw - 30)
        };
        let mut chart = ChartBuilder::on(&plot)
            .margin(MARGIN)
            .x_label_area_size(BOTTOM)
            .y_label_area_size(LEFT)
            .build_cartesian_2d(lo[0]..hi[0], lo[1]..hi[1])
            .map_err(draw_err)?;
        chart
            .configure_mesh()
            .x_desc("x (m)")
            .y_desc("y (m)")
            .label_style(font(TICK_PX))
            .axis_desc_style(font(LABEL_PX))
            .x_label_formatter(&|v| format_number(*v))
            .y_label_formatter(&|v| format_number(*v))
            .x_labels(10)
            .y_labels(10)
            .light_line_style(WHITE.mix(0.0))
            .bold_line_style(RGBColor(236, 236, 236))
            .axis_style(BLACK.stroke_width(2))
            .draw()
            .map_err(draw_err)?;
        let px_per_m = self.layout.px_per_m();
        match m.base {
            MapBase::Empty => {}
            MapBase::World(w) => draw_world(&mut chart, w)?,
            MapBase::Grid(g) => draw_grid(&mut chart, g, px_per_m)?,
        }
        if let Some(c) = &m.cells {
            draw_cells(&mut chart, c, px_per_m)?;
        }
        for p in &m.paths {
            let pts: Vec<(f64, f64)> = p
                .points
                .iter()
                .filter(|q| q[0].is_finite() && q[1].is_finite())
                .map(|q| (q[0], q[1]))
                .collect();
            let style = rgb(p.colour).stroke_width(p.width);
            if p.dashed {
                chart
                    .draw_series(DashedLineSeries::new(pts, 14, 9, style))
                    .map_err(draw_err)?;
            } else {
                chart
                    .draw_series(LineSeries::new(pts, style))
                    .map_err(draw_err)?;
            }
        }
        let bar_scale = m
            .cells
            .as_ref()
            .filter(|c| c.categories.is_empty())
            .map(|c| (c.scale, c.label.clone()))
            .or_else(|| {
                m.value_path
                    .as_ref()
                    .map(|v| (v.scale, v.colour_label.clone()))
            });
        if let Some(v) = &m.value_path {
            let scale = bar_scale.as_ref().map_or(v.scale, |b| b.0);
            draw_value_path(&mut chart, v, &scale)?;
        }
        for s in &m.shapes {
            let col = rgb(s.colour);
            let r = match s.kind {
                ShapeKind::Ellipse {
                    centre,
                    semi_axes,
                    angle,
                } => chart.draw_series(std::iter::once(PathElement::new(
                    circle_points(centre, semi_axes.0, semi_axes.1, angle, 48),
                    col.stroke_width(2),
                ))),
                ShapeKind::Dot { centre, radius_px } => chart.draw_series(std::iter::once(
                    Circle::new((centre[0], centre[1]), radius_px, col.filled()),
                )),
                ShapeKind::Segment { from, to } => {
                    chart.draw_series(std::iter::once(PathElement::new(
                        vec![(from[0], from[1]), (to[0], to[1])],
                        col.stroke_width(4),
                    )))
                }
            };
            r.map_err(draw_err)?;
        }
        draw_scale_bar(root, &chart, lo, hi)?;
        if let Some((scale, label)) = &bar_scale {
            let top = chart.backend_coord(&(lo[0], hi[1])).1
                - header_height(&m.title, &m.subtitle) as i32;
            let bottom = chart.backend_coord(&(lo[0], lo[1])).1
                - header_height(&m.title, &m.subtitle) as i32;
            draw_colour_bar(&bar, scale, label, top, bottom)?;
        }
        draw_legend(&legend, &entries)
    }
}
