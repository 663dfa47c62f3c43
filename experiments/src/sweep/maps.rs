//! Per-location error maps of a sweep (issue 9, deliverable 3; [004] §3,
//! Figure 2). With `[error_map] resolution = R` in the sweep file every trial adds each scored
//! instant's position error to the cell of the robot's true position
//! ([`atrium_scenarios::error_maps::accumulate`]) and its map is written, atomically, to
//! `maps/c<cell>_t<trial>.csv` *before* the trial's rows join `results.csv`: a recorded trial
//! always has its map. The final maps are sums of the per-trial files taken in (cell, trial)
//! order, so an unsharded run, a resumed run and merged shards add the same numbers in the same
//! order and write byte-identical `error_map.csv` files.
//!
//! Outputs (one set per cell; with more than one cell the names get `_c<cell>`):
//! `error_map.csv` ([`ErrorMap::to_csv`], what the data-driven sensor chooser loads),
//! `error_map_<localizer>.png` (the world, each visited cell coloured by the localizer's mean
//! error on a log scale from 1 cm to 10 m) and `error_map_best.png` (each cell coloured by the
//! localizer with the lowest mean error, with a legend). `maps/world_c<cell>.json` keeps the
//! cell's world so `sweep merge` can draw without the sweep file.

use super::heatmap::{colour_bar, fill, heat_colour, scale_t};
use super::text;
use atrium_localization::error_map::ErrorMap;
use atrium_scenarios::error::ScenarioError;
use atrium_worlds::World;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use tiny_skia::{Color, Pixmap};

/// Lower and upper end of the error colour scale, m.
pub const SCALE_M: (f64, f64) = (0.01, 10.0);
const PX_PER_M: f64 = 14.0;
const MARGIN: f64 = 24.0;
const RIGHT: f64 = 150.0;
const TOP: f64 = 34.0;

/// Colours of the "best localizer" picture, by layer.
const PALETTE: [[u8; 3]; 8] = [
    [31, 119, 180],
    [255, 127, 14],
    [44, 160, 44],
    [214, 39, 40],
    [148, 103, 189],
    [140, 86, 75],
    [227, 119, 194],
    [23, 190, 207],
];

fn io(path: &Path) -> impl Fn(std::io::Error) -> ScenarioError + '_ {
    move |err| ScenarioError::Io {
        file: path.to_path_buf(),
        err,
    }
}

pub fn maps_dir(out: &Path) -> PathBuf {
    out.join("maps")
}

pub fn trial_map_path(out: &Path, cell: usize, trial: usize) -> PathBuf {
    maps_dir(out).join(format!("c{cell}_t{trial}.csv"))
}

fn world_path(out: &Path, cell: usize) -> PathBuf {
    maps_dir(out).join(format!("world_c{cell}.json"))
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), ScenarioError> {
    let failed = |file: &Path| {
        let file = file.to_path_buf();
        move |err| ScenarioError::Write { file, err }
    };
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(failed(dir))?;
    }
    atrium_scenarios::output::write_atomic(path, bytes).map_err(failed(path))
}

/// Records the world of `cell` (once) so the pictures can be drawn from the folder alone.
pub fn write_world(out: &Path, cell: usize, world: &World) -> Result<(), ScenarioError> {
    let p = world_path(out, cell);
    if p.exists() {
        return Ok(());
    }
    let json = serde_json::to_string(world)
        .map_err(|e| ScenarioError::field(&p, "world", e.to_string()))?;
    write(&p, json.as_bytes())
}

pub fn write_trial_map(
    out: &Path,
    cell: usize,
    trial: usize,
    map: &ErrorMap,
) -> Result<(), ScenarioError> {
    write(&trial_map_path(out, cell, trial), map.to_csv().as_bytes())
}

fn read_map(path: &Path) -> Result<ErrorMap, ScenarioError> {
    let text = std::fs::read_to_string(path).map_err(io(path))?;
    ErrorMap::from_csv(&text)
        .map_err(|e| ScenarioError::field(path, format!("line {}", e.line), e.message))
}

/// Copies every file of `from/maps` into `to/maps` (merging shards).
pub fn copy_maps(from: &Path, to: &Path) -> Result<usize, ScenarioError> {
    let src = maps_dir(from);
    if !src.is_dir() {
        return Ok(0);
    }
    let mut n = 0;
    for entry in std::fs::read_dir(&src).map_err(io(&src))? {
        let entry = entry.map_err(io(&src))?;
        let name = entry.file_name();
        let name_s = name.to_string_lossy();
        if name_s.starts_with('.') || !(name_s.ends_with(".csv") || name_s.ends_with(".json")) {
            continue; // temporary files of an interrupted write
        }
        let bytes = std::fs::read(entry.path()).map_err(io(&entry.path()))?;
        write(&maps_dir(to).join(&name), &bytes)?;
        n += 1;
    }
    Ok(n)
}

/// Sums the per-trial maps of `trials` ((cell, trial), any order) per cell, in (cell, trial)
/// order. A missing file is an error naming it.
pub fn combine(
    out: &Path,
    trials: &[(usize, usize)],
) -> Result<BTreeMap<usize, ErrorMap>, ScenarioError> {
    let mut keys = trials.to_vec();
    keys.sort_unstable();
    keys.dedup();
    let mut maps: BTreeMap<usize, ErrorMap> = BTreeMap::new();
    for (cell, trial) in keys {
        let p = trial_map_path(out, cell, trial);
        let m = read_map(&p)?;
        match maps.get_mut(&cell) {
            None => {
                maps.insert(cell, m);
            }
            Some(acc) => acc
                .merge(&m)
                .map_err(|msg| ScenarioError::field(&p, "grid", msg))?,
        }
    }
    Ok(maps)
}

struct Frame {
    min: [f64; 2],
    max: [f64; 2],
    width: u32,
    height: u32,
}

impl Frame {
    fn of(map: &ErrorMap, world: Option<&World>) -> Frame {
        let (mut min, mut max) = (
            map.origin,
            [
                map.origin[0] + map.width as f64 * map.resolution,
                map.origin[1] + map.height as f64 * map.resolution,
            ],
        );
        if let Some(w) = world {
            let (lo, hi) = w.bounds();
            for k in 0..2 {
                min[k] = min[k].min(lo[k]);
                max[k] = max[k].max(hi[k]);
            }
        }
        Frame {
            min,
            max,
            width: ((max[0] - min[0]) * PX_PER_M + 2.0 * MARGIN + RIGHT).ceil() as u32,
            height: ((max[1] - min[1]) * PX_PER_M + 2.0 * MARGIN + TOP).ceil() as u32,
        }
    }
    fn px(&self, p: [f64; 2]) -> (f64, f64) {
        (
            MARGIN + (p[0] - self.min[0]) * PX_PER_M,
            TOP + MARGIN + (self.max[1] - p[1]) * PX_PER_M,
        )
    }
}

/// Draws `map`'s cells with `colour(i, j)`, then the world on top.
fn picture(
    map: &ErrorMap,
    world: Option<&World>,
    title: &str,
    colour: &dyn Fn(usize, usize) -> Option<[u8; 3]>,
) -> Result<(Pixmap, Frame), String> {
    let f = Frame::of(map, world);
    let mut pm = Pixmap::new(f.width, f.height).ok_or("error map picture too large")?;
    pm.fill(Color::WHITE);
    for j in 0..map.height {
        for i in 0..map.width {
            if let Some(rgb) = colour(i, j) {
                let x0 = map.origin[0] + i as f64 * map.resolution;
                let y1 = map.origin[1] + (j + 1) as f64 * map.resolution;
                let (px, py) = f.px([x0, y1]);
                let s = (map.resolution * PX_PER_M) as f32;
                fill(&mut pm, px as f32, py as f32, s, s, rgb);
            }
        }
    }
    if let Some(w) = world {
        atrium_scenarios::plot::draw_world(&mut pm, w, &|p| f.px(p));
    }
    text::draw(&mut pm, MARGIN as f32, 10.0, 2, [0, 0, 0], title);
    Ok((pm, f))
}

/// `error_map_<localizer>.png`: each visited cell coloured by `layer`'s mean error.
pub fn localizer_png(
    map: &ErrorMap,
    layer: usize,
    world: Option<&World>,
) -> Result<Vec<u8>, String> {
    let (lo, hi) = SCALE_M;
    let title = format!(
        "{}: mean error by true position, m",
        map.localizers.get(layer).map_or("?", |s| s.as_str())
    );
    let colour = |i: usize, j: usize| {
        map.mean(layer, i, j)
            .map(|(m, _)| heat_colour(scale_t(m, lo, hi)))
    };
    let (mut pm, f) = picture(map, world, &title, &colour)?;
    let bx = (f.width as f64 - RIGHT + 24.0) as f32;
    let bh = (f.height as f64 - TOP - 2.0 * MARGIN).max(60.0) as f32;
    colour_bar(&mut pm, bx, (TOP + MARGIN) as f32, bh, lo, hi, "M");
    pm.encode_png().map_err(|e| e.to_string())
}

/// `error_map_best.png`: each cell coloured by the localizer with the lowest mean error.
pub fn best_png(map: &ErrorMap, world: Option<&World>) -> Result<Vec<u8>, String> {
    let colour = |i: usize, j: usize| map.best_layer(i, j).map(|l| PALETTE[l % PALETTE.len()]);
    let (mut pm, f) = picture(map, world, "lowest mean error", &colour)?;
    let x = (f.width as f64 - RIGHT + 16.0) as f32;
    for (l, name) in map.localizers.iter().enumerate() {
        let y = (TOP + MARGIN) as f32 + l as f32 * 22.0;
        fill(&mut pm, x, y, 14.0, 14.0, PALETTE[l % PALETTE.len()]);
        text::draw(&mut pm, x + 20.0, y + 2.0, 2, [0, 0, 0], name);
    }
    pm.encode_png().map_err(|e| e.to_string())
}

/// Writes the CSV and pictures of every cell's map; returns the files written.
pub fn write_outputs(
    out: &Path,
    maps: &BTreeMap<usize, ErrorMap>,
    single_cell: bool,
) -> Result<Vec<PathBuf>, ScenarioError> {
    let mut written = Vec::new();
    for (&cell, map) in maps {
        let suffix = if single_cell {
            String::new()
        } else {
            format!("_c{cell}")
        };
        let wp = world_path(out, cell);
        let world: Option<World> = match std::fs::read_to_string(&wp) {
            Ok(text) => Some(
                serde_json::from_str(&text)
                    .map_err(|e| ScenarioError::field(&wp, "world", e.to_string()))?,
            ),
            Err(_) => None,
        };
        let mut put = |name: String, bytes: Vec<u8>| -> Result<(), ScenarioError> {
            let p = out.join(name);
            write(&p, &bytes)?;
            written.push(p);
            Ok(())
        };
        let draw_err = |e: String| ScenarioError::field(out, "error_map", e);
        put(format!("error_map{suffix}.csv"), map.to_csv().into_bytes())?;
        for (l, name) in map.localizers.iter().enumerate() {
            let png = localizer_png(map, l, world.as_ref()).map_err(draw_err)?;
            put(format!("error_map{suffix}_{name}.png"), png)?;
        }
        put(
            format!("error_map{suffix}_best.png"),
            best_png(map, world.as_ref()).map_err(draw_err)?,
        )?;
    }
    Ok(written)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn combine_sums_in_order_whatever_the_listing() {
        let dir = std::env::temp_dir().join(format!("atrium-maps-{}", std::process::id()));
        let mut a = ErrorMap::new([0.0, 0.0], [2.0, 1.0], 1.0, vec!["l".into()]).unwrap();
        a.add(0, [0.5, 0.5], 0.1);
        let mut b = a.clone();
        b.add(0, [1.5, 0.5], 0.7);
        write_trial_map(&dir, 0, 0, &a).unwrap();
        write_trial_map(&dir, 0, 1, &b).unwrap();
        let m1 = combine(&dir, &[(0, 1), (0, 0)]).unwrap();
        let m2 = combine(&dir, &[(0, 0), (0, 1), (0, 0)]).unwrap();
        assert_eq!(m1[&0].to_csv(), m2[&0].to_csv());
        assert_eq!(m1[&0].mean(0, 0, 0), Some((0.1, 2)));
        assert!(combine(&dir, &[(0, 2)]).is_err());
        let png = best_png(&m1[&0], None).unwrap();
        assert_eq!(&png[1..4], b"PNG");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
