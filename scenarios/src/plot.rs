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
        ..MapFigure::default()
    })
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
}
