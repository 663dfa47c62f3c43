//! Pictures of an EKF-SLAM run in the three modes of Kozlov, MacDonald and Wünsche
//! ([003] §3.2 and §4, Fig. 3–8): the ground-truth and estimated
//! robot paths, the pillars and the estimated features, and a correlation ellipse of the
//! relative covariance P_d (eq. 13) at the midpoint of each feature pair —
//!
//! - `all_pairs`: every pair (Fig. 3, 6);
//! - `inter_cluster`: only pairs whose features lie in different single-linkage clusters
//!   (Fig. 4, 7);
//! - `min_mean_max`: per cluster pair, the pairs with the smallest and largest value and the
//!   mean P_d, at the midpoint of the two cluster centroids (Fig. 5, 8).
//!
//! One frame per snapshot the filter kept (`frames_s`, then the final state), each a
//! [`crate::figure`] map (axes in metres, scale bar, legend) written as SVG and PNG:
//! `slam_<localizer>_<mode>_<frame>.svg` / `.png`. Ellipses are 95 % ellipses (2.45 σ)
//! magnified by one factor per run, stated in the legend, so that frames of a run compare
//! directly. Pairs the monitor had flagged by a frame's time are vermillion.

use crate::figure::colour::OKABE_ITO;
use crate::figure::{map_figure, Figure, FigureError, MapBase, MapFigure, MapPath, MapShape, Rgb};
use crate::runner::{LocalizerRun, RunResult};
use crate::slam::SlamRun;
use atrium_localization::covariance_monitor::{
    largest_eigenvalue, relative_covariance, single_linkage,
};
use atrium_localization::ekf_slam::SlamSnapshot;
use atrium_worlds::World;

/// √χ²₂(0.95): the 95 % ellipse of a 2-D Gaussian is 2.45 σ along each principal axis.
const K95: f64 = 2.447_746_830_680_816;
/// Pixels of the larger side of the drawn area (about: the figure keeps metres square).
const TARGET_PX: f64 = 1300.0;
const MARGIN_M: f64 = 0.6;

pub const MODES: [&str; 3] = ["all_pairs", "inter_cluster", "min_mean_max"];

/// What an ellipse of P_d stands for, and so its colour and legend line.
#[derive(Debug, Clone, Copy, PartialEq)]
enum PairKind {
    Pair,
    Flagged,
    Smallest,
    Mean,
    Largest,
}

impl PairKind {
    fn colour(self) -> Rgb {
        match self {
            PairKind::Pair => OKABE_ITO[0],
            PairKind::Flagged | PairKind::Largest => OKABE_ITO[1],
            PairKind::Smallest => OKABE_ITO[2],
            PairKind::Mean => OKABE_ITO[3],
        }
    }

    fn label(self, mag: f64) -> String {
        let m = crate::figure::format_number(mag);
        match self {
            PairKind::Pair => format!("95 % ellipse of P_d ×{m}"),
            PairKind::Flagged => "pair flagged by the monitor".into(),
            PairKind::Smallest => format!("smallest P_d ×{m}"),
            PairKind::Mean => format!("mean P_d ×{m}"),
            PairKind::Largest => format!("largest P_d ×{m}"),
        }
    }
}

/// Semi-axes (a ≥ b) and major-axis angle of the 95 % ellipse of [[xx, xy], [xy, yy]].
fn ellipse_of(xx: f64, xy: f64, yy: f64) -> (f64, f64, f64) {
    let l1 = largest_eigenvalue(xx, xy, yy).max(0.0);
    let l2 = (xx + yy - l1).max(0.0);
    let angle = 0.5 * (2.0 * xy).atan2(xx - yy);
    (K95 * l1.sqrt(), K95 * l2.sqrt(), angle)
}

fn mid(a: [f64; 2], b: [f64; 2]) -> [f64; 2] {
    [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])]
}

/// A "nice" magnification (1, 2 or 5 × 10ⁿ) that draws an ellipse of semi-axis `a` m at
/// about `target_px` pixels.
fn magnification(a: f64, scale: f64, target_px: f64) -> f64 {
    if !(a.is_finite() && a > 0.0) {
        return 1.0;
    }
    let raw = (target_px / (a * scale)).max(1.0);
    let e = raw.log10().floor();
    let base = 10f64.powf(e);
    let m = raw / base;
    let nice = if m < 2.0 {
        1.0
    } else if m < 5.0 {
        2.0
    } else {
        5.0
    };
    nice * base
}

/// The ellipses of one mode for one snapshot: (centre, P_d as (xx, xy, yy), colour).
fn pair_ellipses(
    snap: &SlamSnapshot,
    mode: &str,
    cluster_distance: f64,
    flagged: &[(usize, usize)],
) -> Vec<([f64; 2], [f64; 3], PairKind)> {
    let n = snap.features();
    let feats: Vec<[f64; 2]> = (0..n).map(|k| snap.feature(k)).collect();
    let cov = snap.map_cov();
    let labels = single_linkage(&feats, cluster_distance);
    let colour = |i: usize, j: usize| {
        if flagged.contains(&(i, j)) {
            PairKind::Flagged
        } else {
            PairKind::Pair
        }
    };
    let mut out = Vec::new();
    match mode {
        "all_pairs" | "inter_cluster" => {
            for j in 1..n {
                for i in 0..j {
                    if mode == "inter_cluster" && labels[i] == labels[j] {
                        continue;
                    }
                    let pd = relative_covariance(&cov, i, j);
                    out.push((mid(feats[i], feats[j]), pd, colour(i, j)));
                }
            }
        }
        _ => {
            let mut ids = labels.clone();
            ids.sort_unstable();
            ids.dedup();
            let centroid = |c: usize| {
                let members: Vec<&[f64; 2]> = feats
                    .iter()
                    .zip(&labels)
                    .filter(|(_, l)| **l == c)
                    .map(|(f, _)| f)
                    .collect();
                let k = members.len().max(1) as f64;
                [
                    members.iter().map(|f| f[0]).sum::<f64>() / k,
                    members.iter().map(|f| f[1]).sum::<f64>() / k,
                ]
            };
            for (ka, &ca) in ids.iter().enumerate() {
                for &cb in &ids[ka + 1..] {
                    let mut best: Option<(f64, [f64; 3])> = None;
                    let mut worst: Option<(f64, [f64; 3])> = None;
                    let mut sum = [0.0; 3];
                    let mut count = 0.0;
                    for j in 1..n {
                        for i in 0..j {
                            let (li, lj) = (labels[i], labels[j]);
                            if !((li == ca && lj == cb) || (li == cb && lj == ca)) {
                                continue;
                            }
                            let pd = relative_covariance(&cov, i, j);
                            let v = largest_eigenvalue(pd[0], pd[1], pd[2]);
                            if best.is_none_or(|(b, _)| v < b) {
                                best = Some((v, pd));
                            }
                            if worst.is_none_or(|(w, _)| v > w) {
                                worst = Some((v, pd));
                            }
                            for k in 0..3 {
                                sum[k] += pd[k];
                            }
                            count += 1.0;
                        }
                    }
                    let at = mid(centroid(ca), centroid(cb));
                    if let (Some((_, lo)), Some((_, hi))) = (best, worst) {
                        out.push((at, hi, PairKind::Largest));
                        out.push((at, sum.map(|s| s / count), PairKind::Mean));
                        out.push((at, lo, PairKind::Smallest));
                    }
                }
            }
        }
    }
    out
}

/// Every picture of one SLAM localizer: (file stem, figure).
pub fn figures(
    world: &World,
    run: &RunResult,
    loc: &LocalizerRun,
    slam: &SlamRun,
) -> Result<Vec<(String, Figure)>, FigureError> {
    let Some(last) = slam.snapshots.last() else {
        return Ok(Vec::new());
    };
    // Area: features, their pillars and both paths, with a margin.
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
    for f in &slam.features {
        grow(f.position);
        if let Some(i) = f.pillar {
            grow(world.pillars[i].center);
        }
    }
    for (_, p) in run.ground_truth.iter().chain(&loc.trajectory) {
        grow([p.x, p.y]);
    }
    if lo[0] > hi[0] {
        return Ok(Vec::new());
    }
    let min = [lo[0] - MARGIN_M, lo[1] - MARGIN_M];
    let max = [hi[0] + MARGIN_M, hi[1] + MARGIN_M];
    let scale = TARGET_PX / (max[0] - min[0]).max(max[1] - min[1]);
    // One magnification per run, from the final frame's median all-pairs ellipse (18 px).
    let mut finals: Vec<f64> = pair_ellipses(last, "all_pairs", slam.cluster_distance, &[])
        .iter()
        .map(|(_, pd, _)| ellipse_of(pd[0], pd[1], pd[2]).0)
        .collect();
    finals.sort_by(f64::total_cmp);
    let mag = magnification(
        finals.get(finals.len() / 2).copied().unwrap_or(0.0),
        scale,
        18.0,
    );

    let mut out = Vec::new();
    let frames = slam.snapshots.len();
    for (fi, snap) in slam.snapshots.iter().enumerate() {
        let label = if fi + 1 == frames {
            "final".to_string()
        } else {
            format!("t{:04.0}", snap.stamp)
        };
        let flagged: Vec<(usize, usize)> = slam
            .monitor
            .violating_pairs
            .iter()
            .filter(|p| p.first_stamp <= snap.stamp + 1e-9)
            .map(|p| (p.i, p.j))
            .collect();
        for mode in MODES {
            let mut fig = frame_figure(world, run, loc, slam, snap, mode, mag, &flagged);
            fig.view = Some((min, max));
            fig.title = format!(
                "{}: {} mode, t = {:.1} s",
                crate::plot::run_title(run, loc),
                mode.replace('_', " "),
                snap.stamp,
            );
            fig.subtitle = format!(
                "{} features; 95 % ellipses of the relative covariance P_d, magnified ×{}",
                snap.features(),
                crate::figure::format_number(mag)
            );
            out.push((
                format!("slam_{}_{}_{}", loc.name, mode, label),
                map_figure(&fig)?,
            ));
        }
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn frame_figure<'a>(
    world: &'a World,
    run: &RunResult,
    loc: &LocalizerRun,
    slam: &SlamRun,
    snap: &SlamSnapshot,
    mode: &str,
    mag: f64,
    flagged: &[(usize, usize)],
) -> MapFigure<'a> {
    let upto = |v: &[(f64, atrium_robots::Pose2)]| -> Vec<[f64; 2]> {
        v.iter()
            .filter(|(t, _)| *t <= snap.stamp + 1e-9)
            .map(|(_, p)| [p.x, p.y])
            .collect()
    };
    let estimate = OKABE_ITO[2];
    let paths = vec![
        MapPath::new("ground truth", upto(&run.ground_truth)).width(3),
        MapPath::new(format!("{} estimate", loc.name), upto(&loc.trajectory)).colour(estimate),
    ];
    let mut shapes = Vec::new();
    for (c, pd, kind) in pair_ellipses(snap, mode, slam.cluster_distance, flagged) {
        let (a, b, angle) = ellipse_of(pd[0], pd[1], pd[2]);
        shapes.push(
            MapShape::ellipse(c, (a * mag, b * mag), angle, kind.colour()).label(kind.label(mag)),
        );
    }
    for k in 0..snap.features() {
        let f = snap.feature(k);
        let (a, b, angle) = ellipse_of(
            snap.cov(3 + 2 * k, 3 + 2 * k),
            snap.cov(3 + 2 * k, 4 + 2 * k),
            snap.cov(4 + 2 * k, 4 + 2 * k),
        );
        let (colour, label) = if slam.fault_features.contains(&k) {
            (OKABE_ITO[4], "faulty feature (95 %)")
        } else {
            (OKABE_ITO[5], "feature estimate (95 %)")
        };
        shapes.push(MapShape::ellipse(f, (a * mag, b * mag), angle, colour).label(label));
        shapes.push(MapShape::dot(f, 5, colour));
    }
    // The robot estimate: a dot with a heading stroke.
    let (x, y, th) = (snap.state[0], snap.state[1], snap.state[2]);
    shapes.push(MapShape::dot([x, y], 9, estimate).label("robot estimate"));
    shapes.push(
        MapShape::segment(
            [x, y],
            [x + 0.4 * th.cos(), y + 0.4 * th.sin()],
            OKABE_ITO[3],
        )
        .label("estimated heading"),
    );
    MapFigure {
        base: MapBase::World(world),
        paths,
        shapes,
        ..MapFigure::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ellipse_axes_and_angle() {
        // diag(4, 1): semi-axes 2.45·2 and 2.45·1 along x.
        let (a, b, ang) = ellipse_of(4.0, 0.0, 1.0);
        assert!((a - 2.0 * K95).abs() < 1e-12 && (b - K95).abs() < 1e-12 && ang.abs() < 1e-12);
        // [[1, 0.5], [0.5, 1]]: eigenvalues 1.5 (along 45°) and 0.5.
        let (a, b, ang) = ellipse_of(1.0, 0.5, 1.0);
        assert!((a - K95 * 1.5f64.sqrt()).abs() < 1e-12);
        assert!((b - K95 * 0.5f64.sqrt()).abs() < 1e-12);
        assert!((ang - std::f64::consts::FRAC_PI_4).abs() < 1e-12);
    }

    #[test]
    fn magnification_is_a_nice_number() {
        // 1 cm at 100 px/m is 1 px: ×10 gives the 10 px asked for.
        assert_eq!(magnification(0.01, 100.0, 10.0), 10.0);
        assert_eq!(magnification(0.01, 100.0, 30.0), 20.0);
        assert_eq!(magnification(1.0, 100.0, 10.0), 1.0);
        assert_eq!(magnification(0.0, 100.0, 10.0), 1.0);
    }
}
