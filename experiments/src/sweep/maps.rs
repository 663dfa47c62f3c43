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
//! `error_map_<localizer>.png` / `.svg` (the world, each visited cell coloured by the
//! localizer's mean error on a logarithmic viridis scale from 1 cm to 10 m, colour bar in
//! metres) and `error_map_best.png` / `.svg` (each cell coloured by the localizer with the
//! lowest mean error, Okabe–Ito colours named in the legend). `maps/world_c<cell>.json`
//! keeps the cell's world so `sweep merge` can draw without the sweep file.

use atrium_localization::error_map::ErrorMap;
use atrium_scenarios::error::ScenarioError;
use atrium_scenarios::figure::{
    self, colour::line_colour, ColourMap, ColourScale, Figure, FigureError, MapBase, MapCells,
    MapFigure,
};
use atrium_worlds::World;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// Lower and upper end of the error colour scale, m (fixed, so maps compare).
pub const SCALE_M: (f64, f64) = (0.01, 10.0);

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

fn base(world: Option<&World>) -> MapBase<'_> {
    world.map_or(MapBase::Empty, MapBase::World)
}

/// `error_map_<localizer>`: each visited cell coloured by `layer`'s mean error.
pub fn localizer_figure(
    sweep: &str,
    map: &ErrorMap,
    layer: usize,
    world: Option<&World>,
) -> Result<Figure, FigureError> {
    let name = map.localizers.get(layer).map_or("?", |s| s.as_str());
    let values = (0..map.height)
        .flat_map(|j| (0..map.width).map(move |i| (i, j)))
        .map(|(i, j)| map.mean(layer, i, j).map(|(m, _)| m))
        .collect();
    let mut cells = MapCells::new(
        map.origin,
        map.resolution,
        (map.width, map.height),
        values,
        "mean position error (m)",
        true,
    );
    cells.scale = ColourScale {
        lo: SCALE_M.0,
        hi: SCALE_M.1,
        log: true,
        map: ColourMap::Viridis,
    };
    figure::map_figure(&MapFigure {
        title: format!("Sweep {sweep}: mean position error of {name} by true position"),
        subtitle: format!(
            "every scored instant of every trial added to the cell of the robot's true \
             position ({} m cells); white: never visited",
            figure::format_number(map.resolution)
        ),
        base: base(world),
        cells: Some(cells),
        ..MapFigure::default()
    })
}

/// `error_map_best`: each cell coloured by the localizer with the lowest mean error.
pub fn best_figure(
    sweep: &str,
    map: &ErrorMap,
    world: Option<&World>,
) -> Result<Figure, FigureError> {
    let values = (0..map.height)
        .flat_map(|j| (0..map.width).map(move |i| (i, j)))
        .map(|(i, j)| map.best_layer(i, j))
        .collect();
    let categories = map
        .localizers
        .iter()
        .enumerate()
        .map(|(l, n)| (format!("{n} lowest"), line_colour(l)))
        .collect();
    figure::map_figure(&MapFigure {
        title: format!("Sweep {sweep}: the localizer with the lowest mean error per location"),
        subtitle: format!(
            "{} m cells; white: never visited",
            figure::format_number(map.resolution)
        ),
        base: base(world),
        cells: Some(MapCells::categorical(
            map.origin,
            map.resolution,
            (map.width, map.height),
            values,
            categories,
        )),
        ..MapFigure::default()
    })
}

/// Writes the CSV and pictures of every cell's map; returns the files written.
pub fn write_outputs(
    out: &Path,
    sweep: &str,
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
        let csv = out.join(format!("error_map{suffix}.csv"));
        write(&csv, map.to_csv().as_bytes())?;
        written.push(csv);
        let fig_err = |e| ScenarioError::figure(out, e);
        for (l, name) in map.localizers.iter().enumerate() {
            let fig = localizer_figure(sweep, map, l, world.as_ref()).map_err(fig_err)?;
            written.extend(
                fig.write(out, &format!("error_map{suffix}_{name}"))
                    .map_err(fig_err)?,
            );
        }
        let fig = best_figure(sweep, map, world.as_ref()).map_err(fig_err)?;
        written.extend(
            fig.write(out, &format!("error_map{suffix}_best"))
                .map_err(fig_err)?,
        );
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
        let fig = best_figure("s", &m1[&0], None).unwrap();
        assert!(fig.svg().contains("l lowest"));
        assert_eq!(&fig.png().unwrap()[1..4], b"PNG");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
