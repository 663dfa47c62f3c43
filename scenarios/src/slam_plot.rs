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
//! One frame per snapshot the filter kept (`frames_s`, then the final state), each as SVG
//! (with legend) and PNG: `slam_<localizer>_<mode>_<frame>.svg` / `.png`. Ellipses are 95 %
//! ellipses (2.45 σ) magnified by one factor per run, stated in the legend, so that frames
//! of a run compare directly. Pairs the monitor had flagged by a frame's time are red.

use crate::runner::{LocalizerRun, RunResult};
use crate::slam::SlamRun;
use atrium_localization::covariance_monitor::{
    largest_eigenvalue, relative_covariance, single_linkage,
};
use atrium_localization::ekf_slam::SlamSnapshot;
use atrium_worlds::geometry::wall_corners;
use atrium_worlds::{LaserBehaviour, World};
use std::fmt::Write;

/// √χ²₂(0.95): the 95 % ellipse of a 2-D Gaussian is 2.45 σ along each principal axis.
const K95: f64 = 2.447_746_830_680_816;
/// Pixels of the larger side of the drawn area.
const TARGET_PX: f64 = 900.0;
const MARGIN_M: f64 = 0.6;
const LEGEND_PX: f64 = 54.0;

pub const MODES: [&str; 3] = ["all_pairs", "inter_cluster", "min_mean_max"];

#[derive(Debug, Clone)]
enum Item {
    /// Filled polygon, world coordinates.
    Poly { pts: Vec<[f64; 2]>, rgba: [u8; 4] },
    /// Open polyline.
    Line {
        pts: Vec<[f64; 2]>,
        rgba: [u8; 4],
        width: f64,
    },
    /// Circle of radius `r` m, at least `min_px` pixels.
    Disc {
        c: [f64; 2],
        r: f64,
        min_px: f64,
        rgba: [u8; 4],
    },
    /// Ellipse outline: semi-axes (m) and the major axis' angle.
    Ellipse {
        c: [f64; 2],
        a: f64,
        b: f64,
        angle: f64,
        rgba: [u8; 4],
        width: f64,
    },
}

struct View {
    min: [f64; 2],
    scale: f64,
    width: f64,
    height: f64,
}

impl View {
    fn px(&self, p: [f64; 2]) -> (f64, f64) {
        (
            (p[0] - self.min[0]) * self.scale,
            self.height - LEGEND_PX - (p[1] - self.min[1]) * self.scale,
        )
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
) -> Vec<([f64; 2], [f64; 3], [u8; 4])> {
    let n = snap.features();
    let feats: Vec<[f64; 2]> = (0..n).map(|k| snap.feature(k)).collect();
    let cov = snap.map_cov();
    let labels = single_linkage(&feats, cluster_distance);
    let colour = |i: usize, j: usize| {
        if flagged.contains(&(i, j)) {
            [220, 30, 30, 230]
        } else {
            [40, 90, 200, 170]
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
                        out.push((at, hi, [220, 40, 40, 230]));
                        out.push((at, sum.map(|s| s / count), [240, 150, 20, 230]));
                        out.push((at, lo, [30, 160, 60, 230]));
                    }
                }
            }
        }
    }
    out
}

/// Every picture of one SLAM localizer: (file name, bytes).
pub fn pictures(
    world: &World,
    run: &RunResult,
    loc: &LocalizerRun,
    slam: &SlamRun,
) -> Result<Vec<(String, Vec<u8>)>, String> {
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
    let (w_m, h_m) = (
        hi[0] - lo[0] + 2.0 * MARGIN_M,
        hi[1] - lo[1] + 2.0 * MARGIN_M,
    );
    let scale = (TARGET_PX / w_m.max(h_m)).clamp(10.0, 400.0);
    let view = View {
        min,
        scale,
        width: (w_m * scale).ceil(),
        height: (h_m * scale).ceil() + LEGEND_PX,
    };
    // One magnification per run, from the final frame's median all-pairs ellipse (12 px).
    let mut finals: Vec<f64> = pair_ellipses(last, "all_pairs", slam.cluster_distance, &[])
        .iter()
        .map(|(_, pd, _)| ellipse_of(pd[0], pd[1], pd[2]).0)
        .collect();
    finals.sort_by(f64::total_cmp);
    let mag = magnification(
        finals.get(finals.len() / 2).copied().unwrap_or(0.0),
        scale,
        12.0,
    );

    let mut files = Vec::new();
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
            let items = frame_items(world, run, loc, slam, snap, mode, mag, &flagged);
            let title = format!(
                "{} / {}: {} at t = {:.1} s, {} features; 95 % ellipses of P_d ×{} (blue; red: flagged)",
                run.scenario,
                loc.name,
                mode.replace('_', " "),
                snap.stamp,
                snap.features(),
                mag
            );
            let base = format!("slam_{}_{}_{}", loc.name, mode, label);
            files.push((
                format!("{base}.svg"),
                svg(&view, &items, &title).into_bytes(),
            ));
            files.push((format!("{base}.png"), png(&view, &items)?));
        }
    }
    Ok(files)
}

#[allow(clippy::too_many_arguments)]
fn frame_items(
    world: &World,
    run: &RunResult,
    loc: &LocalizerRun,
    slam: &SlamRun,
    snap: &SlamSnapshot,
    mode: &str,
    mag: f64,
    flagged: &[(usize, usize)],
) -> Vec<Item> {
    let mut items = Vec::new();
    for wall in &world.walls {
        let glass = world
            .materials
            .iter()
            .any(|m| m.name == wall.material && matches!(m.laser, LaserBehaviour::Glass { .. }));
        items.push(Item::Poly {
            pts: wall_corners(wall.a, wall.b, wall.thickness).to_vec(),
            rgba: if glass {
                [126, 200, 227, 160]
            } else {
                [85, 85, 85, 255]
            },
        });
    }
    for p in &world.pillars {
        items.push(Item::Disc {
            c: p.center,
            r: p.radius,
            min_px: 3.0,
            rgba: [110, 110, 110, 255],
        });
    }
    let upto = |v: &[(f64, atrium_robots::Pose2)]| -> Vec<[f64; 2]> {
        v.iter()
            .filter(|(t, _)| *t <= snap.stamp + 1e-9)
            .map(|(_, p)| [p.x, p.y])
            .collect()
    };
    items.push(Item::Line {
        pts: upto(&run.ground_truth),
        rgba: [0, 0, 0, 255],
        width: 1.5,
    });
    items.push(Item::Line {
        pts: upto(&loc.trajectory),
        rgba: [30, 170, 60, 255],
        width: 2.0,
    });
    for (c, pd, rgba) in pair_ellipses(snap, mode, slam.cluster_distance, flagged) {
        let (a, b, angle) = ellipse_of(pd[0], pd[1], pd[2]);
        items.push(Item::Ellipse {
            c,
            a: a * mag,
            b: b * mag,
            angle,
            rgba,
            width: 1.2,
        });
    }
    for k in 0..snap.features() {
        let f = snap.feature(k);
        let (a, b, angle) = ellipse_of(
            snap.cov(3 + 2 * k, 3 + 2 * k),
            snap.cov(3 + 2 * k, 4 + 2 * k),
            snap.cov(4 + 2 * k, 4 + 2 * k),
        );
        let faulty = slam.fault_features.contains(&k);
        let rgba = if faulty {
            [200, 0, 200, 255]
        } else {
            [0, 170, 200, 255]
        };
        items.push(Item::Ellipse {
            c: f,
            a: a * mag,
            b: b * mag,
            angle,
            rgba,
            width: 1.0,
        });
        items.push(Item::Disc {
            c: f,
            r: 0.0,
            min_px: 3.0,
            rgba,
        });
    }
    // The robot estimate: a green disc with a yellow heading arrow.
    let (x, y, th) = (snap.state[0], snap.state[1], snap.state[2]);
    items.push(Item::Disc {
        c: [x, y],
        r: 0.0,
        min_px: 5.0,
        rgba: [30, 170, 60, 255],
    });
    items.push(Item::Line {
        pts: vec![[x, y], [x + 0.3 * th.cos(), y + 0.3 * th.sin()]],
        rgba: [230, 200, 0, 255],
        width: 3.0,
    });
    items
}

fn rgba_css(c: [u8; 4]) -> String {
    format!(
        r#"rgb({},{},{})" opacity="{:.2}"#,
        c[0],
        c[1],
        c[2],
        c[3] as f64 / 255.0
    )
}

fn svg(view: &View, items: &[Item], title: &str) -> String {
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0}" height="{h:.0}" viewBox="0 0 {w:.0} {h:.0}" font-family="sans-serif" font-size="12">"#,
        w = view.width,
        h = view.height
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    for it in items {
        match it {
            Item::Poly { pts, rgba } => {
                let p: Vec<String> = pts
                    .iter()
                    .map(|p| view.px(*p))
                    .map(|(x, y)| format!("{x:.1},{y:.1}"))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"<polygon points="{}" fill="{}"/>"#,
                    p.join(" "),
                    rgba_css(*rgba)
                );
            }
            Item::Line { pts, rgba, width } => {
                if pts.len() < 2 {
                    continue;
                }
                let p: Vec<String> = pts
                    .iter()
                    .map(|p| view.px(*p))
                    .map(|(x, y)| format!("{x:.1},{y:.1}"))
                    .collect();
                let _ = writeln!(
                    s,
                    r#"<polyline points="{}" fill="none" stroke-width="{width}" stroke="{}/>"#,
                    p.join(" "),
                    rgba_css(*rgba)
                );
            }
            Item::Disc { c, r, min_px, rgba } => {
                let (x, y) = view.px(*c);
                let r = (r * view.scale).max(*min_px);
                let _ = writeln!(
                    s,
                    r#"<circle cx="{x:.1}" cy="{y:.1}" r="{r:.1}" fill="{}/>"#,
                    rgba_css(*rgba)
                );
            }
            Item::Ellipse {
                c,
                a,
                b,
                angle,
                rgba,
                width,
            } => {
                let (x, y) = view.px(*c);
                // SVG's y axis points down, so a counter-clockwise world angle is negative.
                let _ = writeln!(
                    s,
                    r#"<ellipse cx="{x:.1}" cy="{y:.1}" rx="{:.2}" ry="{:.2}" transform="rotate({:.2} {x:.1} {y:.1})" fill="none" stroke-width="{width}" stroke="{}/>"#,
                    (a * view.scale).max(0.5),
                    (b * view.scale).max(0.5),
                    -angle.to_degrees(),
                    rgba_css(*rgba)
                );
            }
        }
    }
    let ly = view.height - LEGEND_PX + 16.0;
    let _ = writeln!(s, r#"<text x="6" y="{ly:.0}">{title}</text>"#);
    let _ = writeln!(
        s,
        r#"<text x="6" y="{:.0}">black: ground truth; green: estimated path and pose; grey: pillars; cyan: features (magenta: fault-injected); min / mean / max: green / orange / red</text>"#,
        ly + 18.0
    );
    s.push_str("</svg>\n");
    s
}

fn png(view: &View, items: &[Item]) -> Result<Vec<u8>, String> {
    use tiny_skia::{Color, FillRule, Paint, PathBuilder, Pixmap, Rect, Stroke, Transform};
    let mut pm = Pixmap::new(view.width as u32, view.height as u32).ok_or("picture too large")?;
    pm.fill(Color::WHITE);
    let paint_of = |c: [u8; 4]| {
        let mut p = Paint {
            anti_alias: true,
            ..Paint::default()
        };
        p.set_color_rgba8(c[0], c[1], c[2], c[3]);
        p
    };
    for it in items {
        match it {
            Item::Poly { pts, rgba } => {
                let mut pb = PathBuilder::new();
                for (i, p) in pts.iter().enumerate() {
                    let (x, y) = view.px(*p);
                    if i == 0 {
                        pb.move_to(x as f32, y as f32);
                    } else {
                        pb.line_to(x as f32, y as f32);
                    }
                }
                pb.close();
                if let Some(path) = pb.finish() {
                    pm.fill_path(
                        &path,
                        &paint_of(*rgba),
                        FillRule::Winding,
                        Transform::identity(),
                        None,
                    );
                }
            }
            Item::Line { pts, rgba, width } => {
                let mut pb = PathBuilder::new();
                for (i, p) in pts.iter().enumerate() {
                    let (x, y) = view.px(*p);
                    if i == 0 {
                        pb.move_to(x as f32, y as f32);
                    } else {
                        pb.line_to(x as f32, y as f32);
                    }
                }
                if let Some(path) = pb.finish() {
                    let stroke = Stroke {
                        width: *width as f32,
                        ..Stroke::default()
                    };
                    pm.stroke_path(
                        &path,
                        &paint_of(*rgba),
                        &stroke,
                        Transform::identity(),
                        None,
                    );
                }
            }
            Item::Disc { c, r, min_px, rgba } => {
                let (x, y) = view.px(*c);
                let r = (r * view.scale).max(*min_px) as f32;
                if let Some(path) = PathBuilder::from_circle(x as f32, y as f32, r) {
                    pm.fill_path(
                        &path,
                        &paint_of(*rgba),
                        FillRule::Winding,
                        Transform::identity(),
                        None,
                    );
                }
            }
            Item::Ellipse {
                c,
                a,
                b,
                angle,
                rgba,
                width,
            } => {
                let (x, y) = view.px(*c);
                let (rx, ry) = (
                    ((a * view.scale).max(0.5)) as f32,
                    ((b * view.scale).max(0.5)) as f32,
                );
                let Some(rect) = Rect::from_xywh(-rx, -ry, 2.0 * rx, 2.0 * ry) else {
                    continue;
                };
                let mut pb = PathBuilder::new();
                pb.push_oval(rect);
                if let Some(path) = pb.finish() {
                    let t = Transform::from_rotate(-angle.to_degrees() as f32)
                        .post_translate(x as f32, y as f32);
                    let stroke = Stroke {
                        width: *width as f32,
                        ..Stroke::default()
                    };
                    pm.stroke_path(&path, &paint_of(*rgba), &stroke, t, None);
                }
            }
        }
    }
    pm.encode_png().map_err(|e| e.to_string())
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
