//! Pictures of a run: the world's walls, the ground-truth path, and a localizer's path
//! coloured by its position error. Written as SVG (with legend) and PNG.

use crate::runner::{LocalizerRun, RunResult};
use atrium_worlds::geometry::wall_corners;
use atrium_worlds::{LaserBehaviour, World};
use std::fmt::Write;

const PX_PER_M: f64 = 20.0;
const MARGIN_PX: f64 = 20.0;
const LEGEND_PX: f64 = 40.0;

/// Error colour scale: green at 1 cm, yellow at 10 cm, red at 1 m and above (log scale), so
/// centimetre tracking and metre-scale failure are both visible in one picture.
pub fn error_colour(e: f64) -> [u8; 3] {
    let t = ((e.max(1e-3) / 0.01).log10() / 2.0).clamp(0.0, 1.0);
    if t < 0.5 {
        let u = t / 0.5;
        [(40.0 + 215.0 * u) as u8, (170.0 + 50.0 * u) as u8, 40]
    } else {
        let u = (t - 0.5) / 0.5;
        [255, (220.0 * (1.0 - u)) as u8, 40]
    }
}

struct Frame {
    min: [f64; 2],
    width: f64,
    height: f64,
}

impl Frame {
    fn of(world: &World) -> Frame {
        let (min, max) = world.bounds();
        Frame {
            min,
            width: (max[0] - min[0]) * PX_PER_M + 2.0 * MARGIN_PX,
            height: (max[1] - min[1]) * PX_PER_M + 2.0 * MARGIN_PX + LEGEND_PX,
        }
    }
    fn px(&self, p: [f64; 2]) -> (f64, f64) {
        (
            MARGIN_PX + (p[0] - self.min[0]) * PX_PER_M,
            self.height - LEGEND_PX - MARGIN_PX - (p[1] - self.min[1]) * PX_PER_M,
        )
    }
}

fn is_glass(world: &World, material: &str) -> bool {
    world
        .materials
        .iter()
        .any(|m| m.name == material && matches!(m.laser, LaserBehaviour::Glass { .. }))
}

/// SVG of one localizer's run.
pub fn svg(world: &World, run: &RunResult, loc: &LocalizerRun) -> String {
    let f = Frame::of(world);
    let mut s = String::new();
    let _ = writeln!(
        s,
        r#"<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0}" height="{h:.0}" viewBox="0 0 {w:.0} {h:.0}" font-family="sans-serif" font-size="12">"#,
        w = f.width,
        h = f.height
    );
    let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
    for wall in &world.walls {
        let c = wall_corners(wall.a, wall.b, wall.thickness);
        let pts: Vec<String> = c
            .iter()
            .map(|p| f.px(*p))
            .map(|(x, y)| format!("{x:.1},{y:.1}"))
            .collect();
        let fill = if is_glass(world, &wall.material) {
            r##"#7ec8e3" fill-opacity="0.6"##
        } else {
            "#555555"
        };
        let _ = writeln!(s, r#"<polygon points="{}" fill="{fill}"/>"#, pts.join(" "));
    }
    for p in &world.pillars {
        let (x, y) = f.px(p.center);
        let _ = writeln!(
            s,
            r##"<circle cx="{x:.1}" cy="{y:.1}" r="{:.1}" fill="#555555"/>"##,
            p.radius * PX_PER_M
        );
    }
    let gt: Vec<String> = run
        .ground_truth
        .iter()
        .map(|(_, p)| f.px([p.x, p.y]))
        .map(|(x, y)| format!("{x:.1},{y:.1}"))
        .collect();
    let _ = writeln!(
        s,
        r#"<polyline points="{}" fill="none" stroke="black" stroke-width="1.5"/>"#,
        gt.join(" ")
    );
    for (w, sample) in loc.trajectory.windows(2).zip(loc.samples.iter().skip(1)) {
        let (x1, y1) = f.px([w[0].1.x, w[0].1.y]);
        let (x2, y2) = f.px([w[1].1.x, w[1].1.y]);
        let [r, g, b] = error_colour(sample.position_error);
        let _ = writeln!(
            s,
            r#"<line x1="{x1:.1}" y1="{y1:.1}" x2="{x2:.1}" y2="{y2:.1}" stroke="rgb({r},{g},{b})" stroke-width="2.5"/>"#
        );
    }
    let ly = f.height - LEGEND_PX + 14.0;
    let _ = writeln!(
        s,
        r#"<text x="{MARGIN_PX}" y="{ly:.0}">{}: {} — black: ground truth; colour: position error</text>"#,
        run.scenario, loc.name
    );
    for (i, e) in [0.01, 0.03, 0.1, 0.3, 1.0].iter().enumerate() {
        let x = MARGIN_PX + i as f64 * 70.0;
        let [r, g, b] = error_colour(*e);
        let _ = writeln!(
            s,
            r#"<rect x="{x:.0}" y="{:.0}" width="14" height="10" fill="rgb({r},{g},{b})"/><text x="{:.0}" y="{:.0}">{e} m</text>"#,
            ly + 8.0,
            x + 18.0,
            ly + 17.0
        );
    }
    s.push_str("</svg>\n");
    s
}

/// Fills `world`'s walls (glass translucent blue, others grey) and pillars into `pm`, `px`
/// mapping a world point to pixels. Shared by the run pictures and the sweep's error maps.
pub fn draw_world(pm: &mut tiny_skia::Pixmap, world: &World, px: &dyn Fn([f64; 2]) -> (f64, f64)) {
    use tiny_skia::{FillRule, Paint, PathBuilder, Pixmap, Transform};
    let mut paint = Paint {
        anti_alias: true,
        ..Paint::default()
    };
    let mut fill_poly = |pm: &mut Pixmap, pts: &[[f64; 2]], rgba: [u8; 4]| {
        let mut pb = PathBuilder::new();
        for (i, p) in pts.iter().enumerate() {
            let (x, y) = px(*p);
            if i == 0 {
                pb.move_to(x as f32, y as f32);
            } else {
                pb.line_to(x as f32, y as f32);
            }
        }
        pb.close();
        if let Some(path) = pb.finish() {
            paint.set_color_rgba8(rgba[0], rgba[1], rgba[2], rgba[3]);
            pm.fill_path(
                &path,
                &paint,
                FillRule::Winding,
                Transform::identity(),
                None,
            );
        }
    };
    for wall in &world.walls {
        let rgba = if is_glass(world, &wall.material) {
            [126, 200, 227, 160]
        } else {
            [85, 85, 85, 255]
        };
        fill_poly(pm, &wall_corners(wall.a, wall.b, wall.thickness), rgba);
    }
    for p in &world.pillars {
        let pts: Vec<[f64; 2]> = (0..24)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 24.0;
                [
                    p.center[0] + p.radius * a.cos(),
                    p.center[1] + p.radius * a.sin(),
                ]
            })
            .collect();
        fill_poly(pm, &pts, [85, 85, 85, 255]);
    }
}

/// PNG of one localizer's run (same picture as the SVG, without text).
pub fn png(world: &World, run: &RunResult, loc: &LocalizerRun) -> Result<Vec<u8>, String> {
    use tiny_skia::{Color, Paint, PathBuilder, Pixmap, Stroke, Transform};
    let f = Frame::of(world);
    let mut pm =
        Pixmap::new(f.width.ceil() as u32, f.height.ceil() as u32).ok_or("picture too large")?;
    pm.fill(Color::WHITE);
    draw_world(&mut pm, world, &|p| f.px(p));
    let line = |pm: &mut Pixmap, a: [f64; 2], b: [f64; 2], rgb: [u8; 3], width: f32| {
        let mut pb = PathBuilder::new();
        let (x1, y1) = f.px(a);
        let (x2, y2) = f.px(b);
        pb.move_to(x1 as f32, y1 as f32);
        pb.line_to(x2 as f32, y2 as f32);
        if let Some(path) = pb.finish() {
            let mut paint = Paint {
                anti_alias: true,
                ..Paint::default()
            };
            paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
            let stroke = Stroke {
                width,
                ..Stroke::default()
            };
            pm.stroke_path(&path, &paint, &stroke, Transform::identity(), None);
        }
    };
    for w in run.ground_truth.windows(2) {
        line(
            &mut pm,
            [w[0].1.x, w[0].1.y],
            [w[1].1.x, w[1].1.y],
            [0, 0, 0],
            1.5,
        );
    }
    for (w, sample) in loc.trajectory.windows(2).zip(loc.samples.iter().skip(1)) {
        line(
            &mut pm,
            [w[0].1.x, w[0].1.y],
            [w[1].1.x, w[1].1.y],
            error_colour(sample.position_error),
            2.5,
        );
    }
    for (i, e) in [0.01, 0.03, 0.1, 0.3, 1.0].iter().enumerate() {
        let x = MARGIN_PX + i as f64 * 70.0;
        let y = f.height - LEGEND_PX + 22.0;
        let rgb = error_colour(*e);
        let rect = tiny_skia::Rect::from_xywh(x as f32, y as f32, 14.0, 10.0).ok_or("legend")?;
        let mut paint = Paint::default();
        paint.set_color_rgba8(rgb[0], rgb[1], rgb[2], 255);
        pm.fill_rect(rect, &paint, Transform::identity(), None);
    }
    pm.encode_png().map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn colour_scale_runs_green_to_red() {
        assert_eq!(error_colour(0.001), [40, 170, 40]);
        assert_eq!(error_colour(0.1), [255, 220, 40]);
        assert_eq!(error_colour(5.0), [255, 0, 40]);
    }
}
