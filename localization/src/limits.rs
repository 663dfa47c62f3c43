//! Limits on every size a scenario or a file can set for a localizer: particle counts, beams,
//! grid resolutions (through the cells they give), training and image sizes, error maps.
//! Each lies far beyond what a real robot or the bundled scenarios use and low enough that
//! what it admits fits in memory and is built in seconds. The checks run before anything is
//! allocated, in f64 or checked arithmetic so that no product can overflow, and their
//! messages start with the field, then give the value, the limit and the constant's name.

/// Particles of a filter with a fixed count (CGR, WiFi, ceiling, omni): about ten f64 buffers
/// each, 80 MB at the limit; the bundled scenarios use at most 20,000.
pub const MAX_PARTICLES: usize = 1_000_000;

/// Particles of a global belief (MCL's `max_particles`, WiFi's `global_particles`), which
/// must cover a whole building at once: about 0.8 GB of buffers at the limit.
pub const MAX_GLOBAL_PARTICLES: usize = 10_000_000;

/// Particles of the appearance filter: each one is weighed against J map samples by a
/// Gaussian over d features per update, so it costs far more than a laser particle.
pub const APF_MAX_PARTICLES: usize = 200_000;

/// J, the map samples per particle of the appearance filter (000 §VII uses 10).
pub const APF_MAX_J: usize = 1_000;

/// Beams or points a filter uses per observation (MCL `max_beams`, CGR `max_points`): a real
/// laser has at most a few thousand beams (the Hokuyo URG-04LX 683), so 100,000 is generous.
pub const MAX_BEAMS: usize = 100_000;

/// CGR gradient refinements per sample (the paper uses 3); each one costs a pass over the
/// observation for every particle.
pub const MAX_REFINEMENTS: usize = 100;

/// FSPF `n_max`, the plane-filtered points kept per depth image (Table 1: 2,000); the point
/// buffers are allocated for this many.
pub const FSPF_MAX_POINTS: usize = 100_000;

/// FSPF `k_max`, neighbourhoods sampled per depth image (Table 1: 20,000): with `l` samples
/// each, the limits below bound a frame to 2·10⁸ samples, well under a second.
pub const FSPF_MAX_NEIGHBOURHOODS: usize = 200_000;

/// FSPF `l`, local samples per neighbourhood (Table 1: 80).
pub const FSPF_MAX_LOCAL_SAMPLES: usize = 1_000;

/// Cells of MCL's likelihood field: 17 bytes a cell (an f64 distance, an f32 likelihood, the
/// cell's state and a u32 free-cell index), so 850 MB at the limit; the campus at the default
/// 0.02 m is 6.6 million cells.
pub const MCL_MAX_GRID_CELLS: u64 = 50_000_000;

/// Cells of CGR's correspondence grid: 36 bytes a cell kept (64 more for a cell near two
/// segments or more) and 48 more while it is built, about 1.7 GB at the limit before those
/// records; the campus at the default 0.1 m is 250,000 cells.
pub const LINE_MAP_MAX_CELLS: u64 = 20_000_000;

/// Values of a WiFi graph, nodes × access points (a mean and a variance each, 160 MB at the
/// limit); every node is a GP prediction, so this also bounds the learning to seconds. The
/// campus at the default 1 m spacing with its 15 access points is 42,000.
pub const WIFI_GRAPH_MAX_VALUES: u64 = 10_000_000;

/// GP hyperparameter fitting (`hyper.blocks`, `hyper.block_size`, `hyper.iterations`): every
/// Nelder–Mead iteration factorises a block_size² matrix per block (defaults 4, 150, 120).
pub const GP_MAX_BLOCKS: usize = 64;
/// See [`GP_MAX_BLOCKS`]: a 1,000-point block is a 1000³/3 flop Cholesky per evaluation.
pub const GP_MAX_BLOCK_SIZE: usize = 1_000;
/// See [`GP_MAX_BLOCKS`].
pub const GP_MAX_ITERATIONS: usize = 10_000;

/// Features of an EKF-SLAM map: the covariance is (2n + 3)² f64 and every update touches all
/// of it, so 5,000 features are 800 MB and about 10⁸ operations per update.
pub const EKF_MAX_FEATURES: usize = 5_000;

/// Snapshots of EKF-SLAM kept for pictures (`frames_s`): each holds the full covariance
/// (8 MB at the default 500 features); the bundled scenarios take one.
pub const EKF_MAX_FRAMES: usize = 100;

/// Training runs (landmark filter, choosers): each is a full simulated drive of the training
/// route, so 100 of a 7-minute route already take hours; the bundled scenarios use 1–3.
pub const MAX_TRAINING_RUNS: usize = 100;

/// Values of an error map, cells × localizer layers: an f64 sum and a u32 count each, so
/// 600 MB at the limit; the campus at 0.5 m with three layers is 30,000.
pub const ERROR_MAP_MAX_VALUES: u64 = 50_000_000;

/// How far (in cells) a data-driven chooser searches an error map around its estimate for a
/// visited cell (default 3): beyond this the map says nothing about where the robot is.
pub const MAX_LOOKUP_RADIUS_CELLS: usize = 100;

/// Training poses of an appearance, omni or ceiling map (000 §VII: 4,104): each is rendered.
pub const TRAINING_MAX_POSES: u64 = 200_000;

/// Pixels of all training images held at once (poses × pixels per image, twice for stereo
/// with disparity), as f32: 1 GB at the limit.
pub const TRAINING_MAX_PIXELS: u64 = 250_000_000;

/// Images a PCA is fitted to (appearance `pca_samples`, omni `pca_locations × rotations`):
/// the snapshot trick diagonalises an N × N matrix, 32 MB and seconds at 2,000 (000 uses
/// 100, 001 uses 320).
pub const MAX_PCA_SAMPLES: usize = 2_000;

/// Values of an omnicam map, nodes × rotations × d (f64): 400 MB at the limit; the bundled
/// omni_lab is 19 × 11 nodes × 32 × 20 = 134,000.
pub const OMNI_MAX_FEATURES: u64 = 50_000_000;

/// A count as it reads best: exact below 10¹⁵, else three significant digits (6e15, 2.51e18).
pub fn fmt_count(n: f64) -> String {
    if n.is_finite() && n < 1e15 {
        return format!("{n:.0}");
    }
    if !n.is_finite() {
        return format!("{n}");
    }
    let s = format!("{n:.2e}");
    match s.split_once('e') {
        Some((m, e)) => {
            let m = m.trim_end_matches('0').trim_end_matches('.');
            format!("{m}e{e}")
        }
        None => s,
    }
}

/// A length as it reads best: up to 3 decimals, trailing zeros dropped (62.3, 1002); out of
/// the decimal range as an exponent (1e-300).
pub fn fmt_length(v: f64) -> String {
    if v != 0.0 && !(1e-7..1e15).contains(&v.abs()) {
        return format!("{v:e}");
    }
    if v != 0.0 && v.abs() < 0.01 {
        return fmt_value(v);
    }
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    s.to_string()
}

/// A value as given, every digit kept (0.000001, 0.0491), or as an exponent out of the
/// decimal range (1e-300).
pub fn fmt_value(v: f64) -> String {
    if v != 0.0 && !(1e-7..1e15).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// Cells of a grid of `resolution` over `extent` (m), in f64 so nothing overflows: each side
/// rounded up, as the grids are built. Infinite for a resolution that is not finite and > 0.
pub fn grid_cells(extent: [f64; 2], resolution: f64) -> f64 {
    lattice_points(extent, resolution, 0.0)
}

/// Points of a lattice of `spacing` over `extent`: each side rounded up, plus `extra` points
/// per axis (nodes around the border).
fn lattice_points(extent: [f64; 2], spacing: f64, extra: f64) -> f64 {
    if !(spacing.is_finite() && spacing > 0.0) {
        return f64::INFINITY;
    }
    let side = |e: f64| (e / spacing - 1e-9).ceil().max(1.0) + extra;
    side(extent[0]) * side(extent[1])
}

/// The finest resolution (m, rounded up to 3 significant digits) at which a grid over
/// `extent` has at most `limit` cells.
pub fn finest_resolution(extent: [f64; 2], limit: u64) -> f64 {
    finest_spacing(extent, 0.0, limit)
}

fn finest_spacing(extent: [f64; 2], extra: f64, limit: u64) -> f64 {
    let fits = |r: f64| lattice_points(extent, r, extra) <= limit as f64;
    // A lower bound: rounding each side up and extra points only add cells.
    let r = (extent[0] * extent[1] / limit as f64).sqrt();
    if !(r.is_finite() && r > 0.0) {
        return r;
    }
    // Up to 3 significant digits, the smallest such value that fits, so it prints as short
    // as it reads (the count only falls as the spacing grows): k / 10^e or k · 10^-e, both
    // correctly rounded.
    let e = 2 - r.log10().floor() as i32;
    let at = |k: f64| {
        if e >= 0 {
            k / 10f64.powi(e)
        } else {
            k * 10f64.powi(-e)
        }
    };
    let mut k = if e >= 0 {
        (r * 10f64.powi(e)).ceil()
    } else {
        (r / 10f64.powi(-e)).ceil()
    };
    for _ in 0..100_000 {
        if fits(at(k)) {
            break;
        }
        k += 1.0;
    }
    at(k)
}

/// Checks a grid of `resolution` over `extent` (the `what`, e.g. "map") against `limit` cells.
/// The message starts with `field` and gives the size the grid would need and the finest
/// resolution that fits.
pub fn check_grid(
    field: &str,
    resolution: f64,
    extent: [f64; 2],
    what: &str,
    limit: u64,
    limit_name: &str,
) -> Result<(), String> {
    Lattice {
        field,
        what,
        unit: "cells",
        extra: 0.0,
        limit,
        limit_name,
    }
    .check(resolution, extent)
}

/// A regular lattice a parameter sets the spacing of, as [`check_grid`] checks it: `unit`
/// (e.g. "nodes") every `spacing` m over the `what`, plus `extra` points per axis.
pub struct Lattice<'a> {
    pub field: &'a str,
    pub what: &'a str,
    pub unit: &'a str,
    pub extra: f64,
    pub limit: u64,
    pub limit_name: &'a str,
}

impl Lattice<'_> {
    /// Checks `spacing` over `extent` against the limit; the message gives the points it
    /// would need and the finest spacing that fits.
    pub fn check(&self, spacing: f64, extent: [f64; 2]) -> Result<(), String> {
        let Lattice {
            field,
            what,
            unit,
            extra,
            limit,
            limit_name,
        } = *self;
        if !(spacing.is_finite() && spacing > 0.0) {
            return Err(format!("{field}: must be finite and > 0, got {spacing}"));
        }
        let points = lattice_points(extent, spacing, extra);
        if points <= limit as f64 {
            return Ok(());
        }
        Err(format!(
            "{field}: {} m over the {} m × {} m {what} is {} {unit}, more than the limit of \
             {limit} ({limit_name}); use a {field} of at least {} m",
            fmt_value(spacing),
            fmt_length(extent[0]),
            fmt_length(extent[1]),
            fmt_count(points),
            fmt_value(finest_spacing(extent, extra, limit)),
        ))
    }
}

/// Checks a count against its limit: `field: N is more than the limit of L (NAME)`.
pub fn check_count(
    field: &str,
    value: usize,
    limit: usize,
    limit_name: &str,
) -> Result<(), String> {
    if value <= limit {
        Ok(())
    } else {
        Err(format!(
            "{field}: {value} is more than the limit of {limit} ({limit_name})"
        ))
    }
}

/// [`check_count`] for a count that must also be at least 1.
pub fn check_count_min1(
    field: &str,
    value: usize,
    limit: usize,
    limit_name: &str,
) -> Result<(), String> {
    if value == 0 {
        return Err(format!("{field}: must be at least 1, got 0"));
    }
    check_count(field, value, limit, limit_name)
}

/// Checks a parameter that must be a finite positive number: `NAME must be finite and > 0,
/// got V` (NaN and infinities included).
pub fn check_positive(name: &str, v: f64) -> Result<(), String> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be finite and > 0, got {v}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_lengths_read_well() {
        assert_eq!(fmt_count(200_000_000.0), "200000000");
        assert_eq!(fmt_count(6e15), "6e15");
        assert_eq!(fmt_count(2.5123e18), "2.51e18");
        assert_eq!(fmt_count(f64::INFINITY), "inf");
        assert_eq!(fmt_length(0.000001), "0.000001");
        assert_eq!(fmt_length(62.3), "62.3");
        assert_eq!(fmt_length(1002.0), "1002");
        assert_eq!(fmt_length(0.02), "0.02");
        assert_eq!(fmt_length(1e-300), "1e-300");
        assert_eq!(fmt_value(0.0491), "0.0491");
        assert_eq!(fmt_value(1e-300), "1e-300");
        assert_eq!(finest_resolution([3000.0, 1000.0], 100), 188.0);
        assert_eq!(finest_resolution([1e6, 1e6], 100), 1e5);
    }

    #[test]
    fn a_grid_over_the_limit_gives_its_size_and_the_finest_resolution_that_fits() {
        let e = check_grid(
            "grid_resolution",
            1e-6,
            [100.0, 60.0],
            "map",
            200_000_000,
            "L",
        )
        .unwrap_err();
        assert_eq!(
            e,
            "grid_resolution: 0.000001 m over the 100 m × 60 m map is 6e15 cells, more than \
             the limit of 200000000 (L); use a grid_resolution of at least 0.00548 m"
        );
        let r = finest_resolution([100.0, 60.0], 200_000_000);
        assert!(grid_cells([100.0, 60.0], r) <= 2e8);
        assert!(grid_cells([100.0, 60.0], r * 0.99) > 2e8);
        assert!(check_grid("g", r, [100.0, 60.0], "map", 200_000_000, "L").is_ok());
        assert!(check_grid("g", f64::NAN, [1.0, 1.0], "map", 10, "L")
            .unwrap_err()
            .contains("g: must be finite and > 0, got NaN"));
        assert!(check_grid("g", 1e-300, [1e300, 1e300], "map", 10, "L").is_err());
    }

    #[test]
    fn counts_at_the_limit_pass_and_above_it_name_field_and_limit() {
        assert!(check_count("max_beams", MAX_BEAMS, MAX_BEAMS, "MAX_BEAMS").is_ok());
        assert_eq!(
            check_count("max_beams", MAX_BEAMS + 1, MAX_BEAMS, "MAX_BEAMS").unwrap_err(),
            "max_beams: 100001 is more than the limit of 100000 (MAX_BEAMS)"
        );
        assert!(check_count_min1("n", 0, 5, "L")
            .unwrap_err()
            .contains("at least 1"));
    }
}
