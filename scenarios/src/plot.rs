//! The picture of a run, per localizer: the world (glass dashed cyan), the ground-truth (or
//! reference) path in black and the localizer's path coloured by its position error on a
//! logarithmic viridis scale with a colour bar in metres; titled with the scenario, the
//! localizer and the seed. Written as `trajectory_<localizer>.png` and `.svg`.

use crate::figure::{
    self, map_figure, ColourScale, Figure, FigureError, MapBase, MapFigure, MapPath, ValuePath,
};
use crate::runner::{LocalizerRun, RunResult};
use atrium_worlds::World;

/// The colour scale of position errors: 1 cm to at least 1 m, logarithmic, so centimetre
/// tracking and metre-scale failure read in one picture (and pictures of runs compare).
pub fn error_scale(max_error: f64) -> ColourScale {
    let hi = if max_error.is_finite() {
        max_error.max(1.0)
    } else {
        1.0
    };
    ColourScale {
        lo: 0.01,
        hi,
        log: true,
        map: figure::ColourMap::Viridis,
    }
}

/// "scenario, localizer (kind), seed N" — how every figure of a run names it.
pub fn run_title(run: &RunResult, loc: &LocalizerRun) -> String {
    format!(
        "{}: {} ({}), seed {}",
        run.scenario, loc.name, loc.kind, run.seed
    )
}

/// The trajectory figure of one localizer's run.
pub fn trajectory_figure(
    world: &World,
    run: &RunResult,
    loc: &LocalizerRun,
) -> Result<Figure, FigureError> {
    let truth_label = if run.log.is_some() {
        "reference"
    } else {
        "ground truth"
    };
    let n = loc.trajectory.len().min(loc.samples.len());
    let points: Vec<[f64; 2]> = loc.trajectory[..n]
        .iter()
        .map(|(_, p)| [p.x, p.y])
        .collect();
    let errors: Vec<f64> = loc.samples[..n].iter().map(|s| s.position_error).collect();
    let max = errors
        .iter()
        .copied()
        .filter(|e| e.is_finite())
        .fold(0.0, f64::max);
    let subtitle = match &loc.metrics {
        Some(m) => format!(
            "{truth_label} black, the estimate coloured by its position error; median {} m, \
             95th percentile {} m, final {} m",
            figure::format_number(m.position_error.median),
            figure::format_number(m.position_error.p95),
            figure::format_number(m.final_position_error),
        ),
        None => format!("{truth_label} black, the estimate coloured by its position error"),
    };
    let truth: Vec<[f64; 2]> = run.ground_truth.iter().map(|(_, p)| [p.x, p.y]).collect();
    let view = path_view(truth.iter().chain(&points), world);
    map_figure(&MapFigure {
        title: run_title(run, loc),
        subtitle,
        base: MapBase::World(world),
        paths: vec![MapPath::new(truth_label, truth).width(3)],
        value_path: Some(ValuePath {
            label: format!("{} estimate", loc.name),
            points,
            values: errors,
            colour_label: "position error (m)".into(),
            scale: error_scale(max),
        }),
        view,
        ..MapFigure::default()
    })
}

/// The part of the world around the paths: their extent with a margin of 10 % (at least
/// 2 m), within the world's bounds. A short run in a large building is then readable.
pub fn path_view<'a>(
    points: impl Iterator<Item = &'a [f64; 2]>,
    world: &World,
) -> Option<([f64; 2], [f64; 2])> {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in points.filter(|p| p[0].is_finite() && p[1].is_finite()) {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if lo[0] > hi[0] {
        return None;
    }
    let margin = (0.1 * (hi[0] - lo[0]).max(hi[1] - lo[1])).max(2.0);
    let (wlo, whi) = if world.walls.is_empty() && world.pillars.is_empty() {
        ([f64::NEG_INFINITY; 2], [f64::INFINITY; 2])
    } else {
        world.bounds()
    };
    let a = [
        (lo[0] - margin).max(wlo[0].min(lo[0])),
        (lo[1] - margin).max(wlo[1].min(lo[1])),
    ];
    let b = [
        (hi[0] + margin).min(whi[0].max(hi[0])),
        (hi[1] + margin).min(whi[1].max(hi[1])),
    ];
    (b[0] > a[0] && b[1] > a[1]).then_some((a, b))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn error_scale_spans_a_centimetre_to_the_worst_error() {
        let s = error_scale(0.3);
        assert_eq!((s.lo, s.hi), (0.01, 1.0));
        assert_eq!(error_scale(7.0).hi, 7.0);
        assert!(s.t(0.1) > 0.45 && s.t(0.1) < 0.55);
    }

    #[test]
    fn a_short_path_is_shown_with_its_surroundings_within_the_world() {
        let world = World::load(
            &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/campus.toml"),
        )
        .unwrap();
        let (wlo, _) = world.bounds();
        let pts = [[2.0, 20.0], [8.0, 20.0]];
        let (lo, hi) = path_view(pts.iter(), &world).unwrap();
        assert_eq!(hi, [10.0, 22.0]);
        assert_eq!(lo, [wlo[0].max(0.0), 18.0]);
    }
}
