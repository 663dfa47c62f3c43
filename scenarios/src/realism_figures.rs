//! The pictures of a realism comparison ([`crate::realism`]): each compared localizer's
//! position error over time on the real log and in its twin (the twin's median over the
//! seeds with their min–max band), the dead reckoning's drift over 10 m stretches as
//! histograms, and both maps (the log's and the twin's, where the reference path is cleared)
//! with the reference and the twin's driven path.

use crate::calibrate::drift::quantile;
use crate::figure::{
    colour, histogram, line_panels, map_figure, Figure, FigureError, Histogram, LineChart, MapBase,
    MapFigure, MapPath, Sample, Series, Threshold,
};
use crate::realism::{Realism, DRIFT_STRETCH_M};
use crate::runner::RunResult;
use crate::scenario::Scenario;

/// Bins of the error-over-time curves: about this many over the run, none shorter than 1 s.
const TIME_BINS: f64 = 300.0;

/// Every realism picture, with the file stem it is written under.
pub fn realism_figures(
    r: &Realism,
    real: &RunResult,
    sims: &[RunResult],
    log_scenario: &Scenario,
    twin: &Scenario,
    converge_threshold_m: f64,
) -> Result<Vec<(String, Figure)>, FigureError> {
    let mut out = vec![(
        "realism_error".to_string(),
        error_over_time(r, real, sims, converge_threshold_m)?,
    )];
    if let Some(d) = &r.drift {
        if !d.real_stretches.is_empty() && !d.sim_stretches.is_empty() {
            out.push((
                "realism_drift".to_string(),
                histogram(&Histogram {
                    title: format!("{}: dead-reckoning drift, real and simulated", r.scenario),
                    subtitle: format!(
                        "position drift over successive {DRIFT_STRETCH_M} m stretches of \
                         the path; real median {:.1} %, twin {:.1} % (seeds {})",
                        d.real.median_pct,
                        d.sim.median_pct,
                        seeds_label(&r.seeds)
                    ),
                    x_label: "drift over a stretch (% of its length)".into(),
                    samples: vec![
                        Sample::new(
                            format!("real log ({} stretches)", d.real_stretches.len()),
                            d.real_stretches.clone(),
                        ),
                        Sample::new(
                            format!(
                                "twin, {} seeds ({} stretches)",
                                sims.len(),
                                d.sim_stretches.len()
                            ),
                            d.sim_stretches.clone(),
                        ),
                    ],
                    bins: 20,
                })?,
            ));
        }
    }
    let twin_path: Vec<[f64; 2]> = sims
        .first()
        .map(|s| s.ground_truth.iter().map(|(_, p)| [p.x, p.y]).collect())
        .unwrap_or_default();
    let reference: Vec<[f64; 2]> = real.ground_truth.iter().map(|(_, p)| [p.x, p.y]).collect();
    for (stem, which, scenario) in [
        ("realism_map_real", "the log's map", log_scenario),
        ("realism_map_twin", "the twin's map", twin),
    ] {
        let Some(map) = &scenario.grid_map else {
            continue;
        };
        let mut paths = vec![MapPath::new("reference (real robot)", reference.clone())
            .colour(colour::TRUTH)
            .width(3)];
        if !twin_path.is_empty() {
            paths.push(
                MapPath::new(
                    format!("twin's robot (seed {})", sims[0].seed),
                    twin_path.clone(),
                )
                .colour(colour::line_colour(1))
                .dashed()
                .width(3),
            );
        }
        out.push((
            stem.to_string(),
            map_figure(&MapFigure {
                title: format!("{}: the real and the twin's path on {which}", r.scenario),
                subtitle: "the twin's map frees the cells within the robot's reach of the \
                           reference, where the real robot drove"
                    .into(),
                base: MapBase::Grid(&map.grid),
                paths,
                ..MapFigure::default()
            })?,
        ));
    }
    Ok(out)
}

/// One panel per compared localizer: the real error and the twin's median with its band.
fn error_over_time(
    r: &Realism,
    real: &RunResult,
    sims: &[RunResult],
    threshold: f64,
) -> Result<Figure, FigureError> {
    let end = real
        .ground_truth
        .last()
        .map_or(real.sim_time_s, |(t, _)| *t)
        .max(1.0);
    let width = (end / TIME_BINS).max(1.0);
    let panels: Vec<LineChart> = r
        .localizers
        .iter()
        .map(|l| {
            let real_curve = binned(errors_of(real, &l.name), width, end);
            let per_seed: Vec<Vec<Option<f64>>> = sims
                .iter()
                .map(|s| binned(errors_of(s, &l.name), width, end))
                .collect();
            let (median, band) = seed_summary(&per_seed, width);
            LineChart {
                title: format!(
                    "{}: real median {:.3} m, twin {:.3} m",
                    l.name, l.real.median, l.sim.median
                ),
                subtitle: String::new(),
                x_label: "time (s)".into(),
                y_label: "position error (m)".into(),
                series: vec![
                    Series::new("real log", points(&real_curve, width)).colour(colour::TRUTH),
                    Series::new(format!("twin, median of {} seeds", sims.len()), median)
                        .with_band(band)
                        .colour(colour::line_colour(1)),
                ],
                thresholds: vec![Threshold::new(threshold, "convergence threshold")],
                y_range: None,
                y_from_zero: true,
            }
        })
        .collect();
    line_panels(
        &format!(
            "{}: position error over time, real and simulated",
            r.scenario
        ),
        &format!(
            "each curve the mean error per {width:.0} s; band: min to max over the twin's \
             seeds {}",
            seeds_label(&r.seeds)
        ),
        &panels,
    )
}

fn errors_of<'a>(run: &'a RunResult, name: &'a str) -> impl Iterator<Item = (f64, f64)> + 'a {
    run.localizers
        .iter()
        .filter(move |l| l.name == name)
        .flat_map(|l| l.samples.iter().map(|s| (s.t, s.position_error)))
}

/// The mean of the values in each bin of `width` over [0, end); `None` where a bin is empty.
pub fn binned(samples: impl Iterator<Item = (f64, f64)>, width: f64, end: f64) -> Vec<Option<f64>> {
    let n = (end / width).ceil().max(1.0) as usize;
    let mut sum = vec![0.0; n];
    let mut count = vec![0usize; n];
    for (t, v) in samples {
        if !(t.is_finite() && v.is_finite()) || t < 0.0 {
            continue;
        }
        let i = ((t / width) as usize).min(n - 1);
        sum[i] += v;
        count[i] += 1;
    }
    sum.iter()
        .zip(&count)
        .map(|(s, &c)| (c > 0).then(|| s / c as f64))
        .collect()
}

fn points(bins: &[Option<f64>], width: f64) -> Vec<(f64, f64)> {
    bins.iter()
        .enumerate()
        .filter_map(|(i, v)| v.map(|v| ((i as f64 + 0.5) * width, v)))
        .collect()
}

/// A curve's (x, median) points and its (x, min, max) band.
type CurveWithBand = (Vec<(f64, f64)>, Vec<(f64, f64, f64)>);

/// Per bin over the seeds that have it: the median, and (x, min, max).
pub fn seed_summary(per_seed: &[Vec<Option<f64>>], width: f64) -> CurveWithBand {
    let n = per_seed.iter().map(Vec::len).max().unwrap_or(0);
    let mut median = Vec::new();
    let mut band = Vec::new();
    let mut values = Vec::with_capacity(per_seed.len());
    for i in 0..n {
        values.clear();
        values.extend(per_seed.iter().filter_map(|s| s.get(i).copied().flatten()));
        if values.is_empty() {
            continue;
        }
        let x = (i as f64 + 0.5) * width;
        median.push((x, quantile(&values, 0.5)));
        band.push((x, quantile(&values, 0.0), quantile(&values, 1.0)));
    }
    (median, band)
}

fn seeds_label(seeds: &[u64]) -> String {
    match seeds {
        [] => String::new(),
        [one] => one.to_string(),
        [first, .., last] if seeds.windows(2).all(|w| w[1] == w[0] + 1) => {
            format!("{first}–{last}")
        }
        _ => seeds
            .iter()
            .map(u64::to_string)
            .collect::<Vec<_>>()
            .join(", "),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bins_average_their_samples_and_leave_empty_ones_out() {
        let b = binned(
            [(0.2, 1.0), (0.8, 3.0), (2.5, 5.0), (9.0, 7.0)].into_iter(),
            1.0,
            3.0,
        );
        // The last sample lies past the end: it joins the last bin.
        assert_eq!(b, vec![Some(2.0), None, Some(6.0)]);
        assert_eq!(points(&b, 1.0), vec![(0.5, 2.0), (2.5, 6.0)]);
    }

    #[test]
    fn seed_summary_takes_median_and_range_of_the_seeds_present() {
        let per_seed = vec![
            vec![Some(1.0), Some(4.0)],
            vec![Some(3.0), None],
            vec![Some(2.0), Some(8.0)],
        ];
        let (m, band) = seed_summary(&per_seed, 2.0);
        assert_eq!(m, vec![(1.0, 2.0), (3.0, 6.0)]);
        assert_eq!(band, vec![(1.0, 1.0, 3.0), (3.0, 4.0, 8.0)]);
    }

    #[test]
    fn seed_ranges_read_as_ranges() {
        assert_eq!(seeds_label(&[1, 2, 3]), "1–3");
        assert_eq!(seeds_label(&[1, 4]), "1, 4");
        assert_eq!(seeds_label(&[7]), "7");
    }
}
