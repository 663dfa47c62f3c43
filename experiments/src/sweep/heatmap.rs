//! `heatmap_<localizer>[_<rest>].png` (issue 9, deliverable 2): per localizer, the sweep's
//! cells on a grid — first axis along x, second along y (one axis: a strip; more: one picture
//! per combination of the remaining axes, named by them) — coloured by the median over trials
//! of each trial's median position error (the summary's "median" column), with the value in
//! each cell, axis labels and a colour bar. Hotter is larger.

use super::csv::Results;
use super::summary;
use super::text;
use tiny_skia::{Color, Paint, Pixmap, Rect, Transform};

/// One axis as the picture labels it.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLabels {
    pub path: String,
    pub values: Vec<String>,
}

/// Minimum cell size in pixels.
pub const CELL_W: u32 = 64;
pub const CELL_H: u32 = 40;
const TOP: u32 = 46;
const BOTTOM: u32 = 44;
const RIGHT: u32 = 110;
const FONT: u32 = 2;

/// The colour scale: t = 0 cold (dark blue) to t = 1 hot (light yellow), through purple, red
/// and orange: monotonic in lightness, so it also reads in grey.
pub fn heat_colour(t: f64) -> [u8; 3] {
    const STOPS: [(f64, [f64; 3]); 5] = [
        (0.0, [20.0, 24.0, 100.0]),
        (0.25, [90.0, 40.0, 160.0]),
        (0.5, [205.0, 50.0, 90.0]),
        (0.75, [250.0, 140.0, 30.0]),
        (1.0, [255.0, 245.0, 120.0]),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let k = STOPS
        .windows(2)
        .position(|w| t <= w[1].0)
        .unwrap_or(STOPS.len() - 2);
    let (t0, a) = STOPS[k];
    let (t1, b) = STOPS[k + 1];
    let u = (t - t0) / (t1 - t0);
    let c = |i: usize| (a[i] + (b[i] - a[i]) * u).round() as u8;
    [c(0), c(1), c(2)]
}

/// Where `v` lies on a scale from `lo` to `hi`: logarithmic when both are positive (errors
/// span centimetres to metres), linear otherwise; 0.5 when the range is empty.
pub fn scale_t(v: f64, lo: f64, hi: f64) -> f64 {
    // Also an empty or NaN range.
    if hi.partial_cmp(&lo) != Some(std::cmp::Ordering::Greater) {
        return 0.5;
    }
    let t = if lo > 0.0 {
        (v.max(lo).ln() - lo.ln()) / (hi.ln() - lo.ln())
    } else {
        (v - lo) / (hi - lo)
    };
    t.clamp(0.0, 1.0)
}

pub(crate) fn fill(pm: &mut Pixmap, x: f32, y: f32, w: f32, h: f32, rgb: [u8; 3]) {
    let mut paint = Paint::default();
    paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
    if let Some(r) = Rect::from_xywh(x, y, w, h) {
        pm.fill_rect(r, &paint, Transform::identity(), None);
    }
}

/// A vertical colour bar at (x, y) of `h` pixels, hot at the top, labelled at both ends and
/// in the middle (on a log scale the middle is the geometric mean), with `title` above.
pub(crate) fn colour_bar(pm: &mut Pixmap, x: f32, y: f32, h: f32, lo: f64, hi: f64, title: &str) {
    let steps = h.max(1.0) as usize;
    for s in 0..steps {
        let t = 1.0 - s as f64 / (steps.max(2) - 1) as f64;
        fill(pm, x, y + s as f32, 16.0, 1.0, heat_colour(t));
    }
    let black = [0, 0, 0];
    text::draw(pm, x, y - 14.0, FONT, black, title);
    let mid = if lo > 0.0 && hi > lo {
        (lo * hi).sqrt()
    } else {
        0.5 * (lo + hi)
    };
    let ty = text::height(FONT) as f32 / 2.0;
    text::draw(pm, x + 22.0, y - ty, FONT, black, &text::number(hi));
    text::draw(
        pm,
        x + 22.0,
        y + h / 2.0 - ty,
        FONT,
        black,
        &text::number(mid),
    );
    text::draw(pm, x + 22.0, y + h - ty, FONT, black, &text::number(lo));
}

/// Turns a label into a file-name part.
pub(crate) fn sanitize(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '.' | '-' | '=') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// Longest file name written (most file systems allow 255 bytes).
const MAX_FILE_NAME: usize = 120;

/// File names for `names` (already sanitized), in order: each kept when it is short and its
/// own; else cut and given a hash of the full name, and numbered if still taken, so two axis
/// values that sanitize alike (`a/b`, `a_b`) never write one file over the other.
pub(crate) fn unique_names(names: Vec<String>) -> Vec<String> {
    let mut taken = std::collections::HashSet::new();
    let mut out = Vec::with_capacity(names.len());
    for name in names {
        let stem = name.strip_suffix(".png").unwrap_or(&name);
        let mut candidate = if name.len() <= MAX_FILE_NAME {
            name.clone()
        } else {
            let cut: String = stem.chars().take(MAX_FILE_NAME - 24).collect();
            format!(
                "{cut}_{}.png",
                &super::inputs::fnv_hex(&[name.as_bytes()])[..8]
            )
        };
        let stem = candidate.trim_end_matches(".png").to_string();
        let mut k = 2;
        while taken.contains(&candidate) {
            candidate = format!("{stem}_{k}.png");
            k += 1;
        }
        taken.insert(candidate.clone());
        out.push(candidate);
    }
    out
}

/// Longest label drawn, characters: longer axis values and paths are cut (with `~`) so a
/// picture's size does not grow with them.
const MAX_LABEL: usize = 24;

/// `s` cut to [`MAX_LABEL`] characters.
pub(crate) fn clip(s: &str) -> String {
    if s.chars().count() <= MAX_LABEL {
        s.to_string()
    } else {
        let mut c: String = s.chars().take(MAX_LABEL - 1).collect();
        c.push('~');
        c
    }
}

/// The largest heat map drawn, pixels (about 160 MB of RGBA): a larger one (thousands of
/// values on one axis) is left out with a note rather than exhausting memory after the run.
pub const MAX_PIXELS: u64 = 40_000_000;

/// Axis indices of cell `cell` (last axis fastest, as [`super::Sweep::cell_indices`]).
pub(crate) fn indices(axes: &[AxisLabels], cell: usize) -> Vec<usize> {
    let mut rem = cell;
    let mut idx = vec![0; axes.len()];
    for (i, a) in axes.iter().enumerate().rev() {
        let n = a.values.len().max(1);
        idx[i] = rem % n;
        rem /= n;
    }
    idx
}

/// The picture's (width, height, left margin, cell width) for the given axes and title.
pub fn size(axes: &[AxisLabels], title: &str) -> (u32, u32, u32, u32) {
    let nx = axes.first().map_or(1, |a| a.values.len()) as u32;
    let ny = axes.get(1).map_or(1, |a| a.values.len()) as u32;
    let cw = axes
        .first()
        .map(|a| {
            a.values
                .iter()
                .map(|v| text::width(v, FONT))
                .max()
                .unwrap_or(0)
                + 8
        })
        .unwrap_or(0)
        .max(CELL_W);
    let left = axes
        .get(1)
        .map(|a| {
            a.values
                .iter()
                .map(|v| text::width(v, FONT))
                .max()
                .unwrap_or(0)
        })
        .unwrap_or(0)
        .max(24)
        + 16;
    let labels = [
        text::width(title, FONT),
        axes.get(1).map_or(0, |a| text::width(&a.path, FONT)),
        axes.first()
            .map_or(0, |a| left + text::width(&a.path, FONT)),
    ];
    let width = (left + nx * cw + RIGHT).max(labels.iter().max().unwrap_or(&0) + 16);
    (width, TOP + ny * CELL_H + BOTTOM, left, cw)
}

/// Top-left pixel of cell (x, y) (x along the first axis, y along the second, row 0 at the
/// bottom as on a plot) in a picture of `axes` titled `title`.
pub fn cell_origin(axes: &[AxisLabels], title: &str, x: usize, y: usize) -> (u32, u32) {
    let (_, _, left, cw) = size(axes, title);
    let ny = axes.get(1).map_or(1, |a| a.values.len()).max(1);
    (
        left + x as u32 * cw,
        TOP + (ny - 1 - y.min(ny - 1)) as u32 * CELL_H,
    )
}

/// The title of localizer `loc`'s picture (`rest`: the other axes' settings).
pub fn title(loc: &str, rest: &[String]) -> String {
    match rest.is_empty() {
        true => format!("{loc}: median error, m"),
        false => format!("{loc}: median error, m ({})", rest.join(", ")),
    }
}

/// One picture: `value(x, y)` is the median error of the cell at (x, y) of this slice.
fn picture(
    axes: &[AxisLabels],
    title: &str,
    value: &dyn Fn(usize, usize) -> Option<f64>,
) -> Result<Vec<u8>, String> {
    let (w, h, left, cw) = size(axes, title);
    let nx = axes.first().map_or(1, |a| a.values.len());
    let ny = axes.get(1).map_or(1, |a| a.values.len());
    let mut pm = Pixmap::new(w, h).ok_or("heat map too large")?;
    pm.fill(Color::WHITE);
    let vals: Vec<f64> = (0..nx)
        .flat_map(|x| (0..ny).map(move |y| (x, y)))
        .filter_map(|(x, y)| value(x, y))
        .filter(|v| v.is_finite())
        .collect();
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let black = [0, 0, 0];
    text::draw(&mut pm, 6.0, 6.0, FONT, black, title);
    let fh = text::height(FONT) as f32;
    for x in 0..nx {
        for y in 0..ny {
            let (px, py) = cell_origin(axes, title, x, y);
            let (px, py) = (px as f32, py as f32);
            let (rgb, label) = match value(x, y) {
                Some(v) if v.is_finite() => {
                    let t = scale_t(v, lo, hi);
                    (heat_colour(t), text::number(v))
                }
                _ => ([225, 225, 225], "-".to_string()),
            };
            fill(&mut pm, px, py, cw as f32 - 1.0, CELL_H as f32 - 1.0, rgb);
            let light = rgb.iter().map(|&c| c as u32).sum::<u32>() > 420;
            let ink = if light { [0, 0, 0] } else { [255, 255, 255] };
            let tw = text::width(&label, FONT) as f32;
            text::draw(
                &mut pm,
                px + (cw as f32 - tw) / 2.0,
                py + (CELL_H as f32 - fh) / 2.0,
                FONT,
                ink,
                &label,
            );
        }
    }
    let grid_bottom = (TOP + ny as u32 * CELL_H) as f32;
    if let Some(a) = axes.first() {
        for (x, v) in a.values.iter().enumerate() {
            let tw = text::width(v, FONT) as f32;
            let px = (left + x as u32 * cw) as f32 + (cw as f32 - tw) / 2.0;
            text::draw(&mut pm, px, grid_bottom + 6.0, FONT, black, v);
        }
        text::draw(
            &mut pm,
            left as f32,
            grid_bottom + 24.0,
            FONT,
            black,
            &a.path,
        );
    }
    if let Some(a) = axes.get(1) {
        for (y, v) in a.values.iter().enumerate() {
            let py = (TOP + (ny - 1 - y) as u32 * CELL_H) as f32 + (CELL_H as f32 - fh) / 2.0;
            text::draw(&mut pm, 6.0, py, FONT, black, v);
        }
        text::draw(&mut pm, 6.0, TOP as f32 - 16.0, FONT, black, &a.path);
    }
    if lo.is_finite() {
        let bx = (left + nx as u32 * cw + 24) as f32;
        let bh = (ny as u32 * CELL_H).max(60) as f32 - 4.0;
        colour_bar(&mut pm, bx, TOP as f32 + 2.0, bh, lo, hi, "M");
    }
    pm.encode_png().map_err(|e| e.to_string())
}

/// The heat maps of a sweep: (file name, PNG bytes), and the pictures left out (too large).
#[derive(Debug, Default)]
pub struct Heatmaps {
    pub pictures: Vec<(String, Vec<u8>)>,
    pub skipped: Vec<String>,
}

/// Every heat map of `results`. `axes` are the sweep's axes in order with their value
/// labels; cells without a result are drawn grey.
pub fn heatmaps(results: &Results, axes: &[AxisLabels]) -> Result<Heatmaps, String> {
    let table = summary::table(results);
    let mut localizers: Vec<&str> = Vec::new();
    for r in &results.rows {
        if !localizers.contains(&r.localizer.as_str()) {
            localizers.push(&r.localizer);
        }
    }
    // Drawn with labels cut short; file names are made from the full values.
    let drawn: Vec<AxisLabels> = axes
        .iter()
        .map(|a| AxisLabels {
            path: clip(&a.path),
            values: a.values.iter().map(|v| clip(v)).collect(),
        })
        .collect();
    let cells: usize = axes.iter().map(|a| a.values.len().max(1)).product();
    let rest_axes = axes.get(2..).unwrap_or(&[]);
    let slices: usize = rest_axes.iter().map(|a| a.values.len().max(1)).product();
    let nx = axes.first().map_or(1, |a| a.values.len().max(1));
    let ny = axes.get(1).map_or(1, |a| a.values.len().max(1));
    let mut out = Heatmaps::default();
    let mut names = Vec::new();
    for loc in &localizers {
        for s in 0..slices {
            let rest = indices(rest_axes, s);
            let suffix: String = rest_axes
                .iter()
                .zip(&rest)
                .map(|(a, &i)| format!("_{}={}", a.path, a.values[i]))
                .collect();
            let name = sanitize(&format!("heatmap_{loc}{suffix}.png"));
            let cell_of = |x: usize, y: usize| {
                // Cell index with indices [x, y, rest...], last axis fastest.
                let idx: Vec<usize> = [x, y]
                    .into_iter()
                    .take(axes.len().min(2))
                    .chain(rest.iter().copied())
                    .collect();
                idx.iter()
                    .zip(axes)
                    .fold(0usize, |c, (&i, a)| c * a.values.len().max(1) + i)
            };
            let value = |x: usize, y: usize| {
                let c = cell_of(x, y);
                (c < cells)
                    .then(|| table.get(&c).and_then(|l| l.get(*loc)).map(|s| s.2))
                    .flatten()
            };
            debug_assert!(nx * ny * slices == cells);
            let rest_text: Vec<String> = drawn
                .get(2..)
                .unwrap_or(&[])
                .iter()
                .zip(&rest)
                .map(|(a, &i)| format!("{} = {}", a.path, a.values[i]))
                .collect();
            let title = title(&clip(loc), &rest_text);
            let (w, h, _, _) = size(&drawn, &title);
            if u64::from(w) * u64::from(h) > MAX_PIXELS {
                out.skipped.push(format!(
                    "{name}: left out: {w} × {h} pixels is more than the limit of \
                     {MAX_PIXELS} (too many values along the first two axes)"
                ));
                continue;
            }
            let png = picture(&drawn, &title, &value)?;
            names.push(name);
            out.pictures.push((String::new(), png));
        }
    }
    for (pic, name) in out.pictures.iter_mut().zip(unique_names(names)) {
        pic.0 = name;
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_scale_is_monotonic_in_brightness() {
        let lum = |t: f64| heat_colour(t).iter().map(|&c| c as u32).sum::<u32>();
        for k in 0..20 {
            assert!(lum(k as f64 / 20.0) < lum((k + 1) as f64 / 20.0));
        }
        assert!((scale_t(0.1, 0.01, 1.0) - 0.5).abs() < 1e-12);
        assert_eq!(scale_t(3.0, 3.0, 3.0), 0.5);
    }

    #[test]
    fn file_names_stay_short_and_distinct() {
        let long = format!("heatmap_l_w={}.png", "x".repeat(300));
        let names = unique_names(vec![
            "heatmap_l_w=a_b.png".into(),
            "heatmap_l_w=a_b.png".into(),
            long.clone(),
            long,
        ]);
        assert_eq!(names[0], "heatmap_l_w=a_b.png");
        assert_eq!(names[1], "heatmap_l_w=a_b_2.png");
        assert!(names[2].len() <= MAX_FILE_NAME && names[2].ends_with(".png"));
        assert_ne!(names[2], names[3]);
    }

    #[test]
    fn pictures_too_large_are_left_out_with_a_note() {
        use super::super::csv::{Results, Row};
        let n = 40_000;
        let axes = vec![AxisLabels {
            path: "p".repeat(500),
            values: (0..n).map(|i| format!("{i}{}", "v".repeat(100))).collect(),
        }];
        let results = Results {
            hash: "h".into(),
            name: "n".into(),
            layout: None,
            axis_paths: vec!["p".into()],
            rows: vec![Row {
                params: vec!["0".into()],
                cell: 0,
                trial: 0,
                seed: 0,
                localizer: "l".into(),
                values: vec!["1".into(); 9],
            }],
            dropped_partial: false,
        };
        let h = heatmaps(&results, &axes).unwrap();
        assert!(h.pictures.is_empty());
        assert!(
            h.skipped[0].contains("heatmap_l.png: left out"),
            "{:?}",
            h.skipped
        );
    }

    #[test]
    fn cells_map_to_their_axis_indices() {
        let axes = vec![
            AxisLabels {
                path: "a".into(),
                values: vec!["1".into(), "2".into()],
            },
            AxisLabels {
                path: "b".into(),
                values: vec!["x".into(), "y".into(), "z".into()],
            },
        ];
        assert_eq!(indices(&axes, 4), vec![1, 1]);
        let (w, h, left, cw) = size(&axes, "t");
        assert_eq!(h, TOP + 3 * CELL_H + BOTTOM);
        assert!(w >= left + 2 * cw + RIGHT);
    }
}
