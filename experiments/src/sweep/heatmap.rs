//! `heatmap_<localizer>[_<rest>].png` and `.svg` (issue 9, deliverable 2; issue 43): per
//! localizer, the sweep's cells on a grid — first axis along x, second along y (one axis: a
//! strip; more: one picture per combination of the remaining axes, named by them) — coloured
//! by the median over trials of each trial's median position error (the summary's "median"
//! column) on a logarithmic viridis scale, with the value written in each cell, the axes named
//! by their parameter paths and a colour bar in metres. Drawn with [`atrium_scenarios::figure`].

use super::csv::Results;
use super::summary;
use atrium_scenarios::figure::{self, Figure};

/// One axis as the picture labels it.
#[derive(Debug, Clone, PartialEq)]
pub struct AxisLabels {
    pub path: String,
    pub values: Vec<String>,
}

/// More cells than this in one picture and it is left out with a note (nothing would be
/// readable).
pub const MAX_CELLS: usize = 4096;

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
const MAX_LABEL: usize = 48;

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

/// The title of localizer `loc`'s picture in sweep `sweep` (`rest`: the other axes'
/// settings).
pub fn title(sweep: &str, loc: &str, rest: &[String]) -> String {
    match rest.is_empty() {
        true => format!("Sweep {sweep}: median position error of {loc}"),
        false => format!(
            "Sweep {sweep}: median position error of {loc} ({})",
            rest.join(", ")
        ),
    }
}

/// Pictures to write: (file stem, figure), and notes on those left out.
#[derive(Debug, Default)]
pub struct Heatmaps {
    pub pictures: Vec<(String, Figure)>,
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
            let title = title(&results.name, &clip(loc), &rest_text);
            if nx * ny > MAX_CELLS {
                out.skipped.push(format!(
                    "{name}: left out: {nx} × {ny} cells is more than the limit of \
                     {MAX_CELLS} (too many values along the first two axes)"
                ));
                continue;
            }
            let values: Vec<Option<f64>> = (0..ny)
                .flat_map(|y| (0..nx).map(move |x| (x, y)))
                .map(|(x, y)| value(x, y))
                .collect();
            let x_axis = drawn.first();
            let y_axis = drawn.get(1);
            let fig = figure::heatmap(&figure::Heatmap {
                title,
                subtitle: format!(
                    "median over trials of each trial's median position error; {} trials",
                    results.rows.iter().filter(|r| r.localizer == *loc).count()
                ),
                x_label: x_axis.map_or(String::new(), |a| a.path.clone()),
                y_label: y_axis.map_or(String::new(), |a| a.path.clone()),
                x_values: x_axis.map_or(vec![String::new()], |a| a.values.clone()),
                y_values: y_axis.map_or(vec![String::new()], |a| a.values.clone()),
                values,
                colour_label: "median position error (m)".into(),
                scale: None,
            })
            .map_err(|e| format!("{name}: {e}"))?;
            names.push(name);
            out.pictures.push((String::new(), fig));
        }
    }
    for (pic, name) in out.pictures.iter_mut().zip(unique_names(names)) {
        pic.0 = name.trim_end_matches(".png").to_string();
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

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
        let n = MAX_CELLS + 1;
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
    }
}
