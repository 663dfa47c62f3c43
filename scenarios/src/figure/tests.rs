use super::*;
use atrium_worlds::World;

fn decode(png: &[u8]) -> (u32, u32, Vec<u8>) {
    let d = png::Decoder::new(std::io::Cursor::new(png));
    let mut r = d.read_info().unwrap();
    let mut buf = vec![0; r.output_buffer_size()];
    let info = r.next_frame(&mut buf).unwrap();
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

/// With `ATRIUM_KEEP_FIGURES=DIR`, the tests' figures are also written there, to look at.
fn keep(fig: &Figure, stem: &str) {
    if let Some(dir) = std::env::var_os("ATRIUM_KEEP_FIGURES") {
        fig.write(std::path::Path::new(&dir), stem).unwrap();
    }
}

fn has_colour(rgb: &[u8], c: Rgb) -> bool {
    rgb.chunks(3).any(|p| p == c)
}

fn texts(svg: &str) -> Vec<String> {
    svg.split("<text")
        .skip(1)
        .filter_map(|t| {
            let body = &t[t.find('>')? + 1..];
            Some(body[..body.find("</text>")?].trim().to_string())
        })
        .collect()
}

#[test]
fn line_chart_has_text_band_threshold_and_a_wide_png() {
    let fig = line_chart(&LineChart {
        title: "Failure rate & width".into(),
        subtitle: "scenario corridor, localizer mcl, seed 7".into(),
        x_label: "corridor width (m)".into(),
        y_label: "failure rate (%)".into(),
        series: vec![
            Series::new("mcl", vec![(2.0, 30.0), (3.0, 12.0), (4.0, 3.0)]).with_band(vec![
                (2.0, 20.0, 40.0),
                (3.0, 8.0, 16.0),
                (4.0, 1.0, 6.0),
            ]),
            Series::new("ekf", vec![(2.0, 50.0), (3.0, 40.0), (4.0, 20.0)]),
        ],
        thresholds: vec![Threshold::new(5.0, "5 % budget")],
        y_range: None,
        y_from_zero: true,
    })
    .unwrap();
    keep(&fig, "line_chart");
    let t = texts(fig.svg());
    for want in [
        "Failure rate &amp; width",
        "scenario corridor, localizer mcl, seed 7",
        "corridor width (m)",
        "failure rate (%)",
        "mcl",
        "ekf",
        "5 % budget (5)",
    ] {
        assert!(t.iter().any(|s| s == want), "no text {want:?} in {t:?}");
    }
    assert!(
        fig.svg().contains("viewBox")
            && fig
                .svg()
                .contains("<title>Failure rate &amp; width</title>")
    );
    let (w, h, px) = decode(&fig.png().unwrap());
    assert!(w >= 1600 && h > 600, "{w}×{h}");
    assert!(
        has_colour(&px, colour::line_colour(0)),
        "the first series' colour is drawn"
    );
    assert!(has_colour(&px, colour::line_colour(1)));
    // The band is the first colour, translucent on white: lighter than the line.
    let band = |p: &[u8]| p[2] > 200 && p[0] > 150 && p[0] < 230 && p[2] > p[0];
    assert!(px.chunks(3).any(band), "the interval band is drawn");
}

#[test]
fn charts_refuse_empty_data() {
    assert!(matches!(
        line_chart(&LineChart::default()),
        Err(FigureError::Empty(_))
    ));
    let h = Histogram {
        title: "t".into(),
        ..Default::default()
    };
    assert!(matches!(histogram(&h), Err(FigureError::Empty(_))));
}

#[test]
fn write_leaves_png_and_svg_and_no_temporary() {
    let dir = std::env::temp_dir().join(format!("atrium-figure-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let fig = histogram(&Histogram {
        title: "Position error".into(),
        subtitle: String::new(),
        x_label: "position error (m)".into(),
        samples: vec![
            Sample::new("real", vec![0.1, 0.2, 0.2, 0.3]),
            Sample::new("twin", vec![0.15, 0.25, 0.4]),
        ],
        bins: 10,
    })
    .unwrap();
    keep(&fig, "histogram");
    let written = fig.write(&dir, "errors").unwrap();
    assert_eq!(
        written,
        vec![dir.join("errors.png"), dir.join("errors.svg")]
    );
    let svg = std::fs::read_to_string(dir.join("errors.svg")).unwrap();
    let t = texts(&svg);
    assert!(
        t.contains(&"real (n = 4)".to_string()) && t.contains(&"twin (n = 3)".to_string()),
        "{t:?}"
    );
    assert!(t.contains(&"share of the sample (%)".to_string()));
    let names: Vec<String> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names.len(), 2, "{names:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn heatmap_writes_values_axis_names_and_colour_bar_unit() {
    let fig = heatmap(&Heatmap {
        title: "Median error".into(),
        subtitle: String::new(),
        x_label: "width (m)".into(),
        y_label: "people".into(),
        x_values: vec!["2".into(), "3".into()],
        y_values: vec!["0".into(), "10".into()],
        values: vec![Some(0.05), Some(0.5), None, Some(2.0)],
        colour_label: "median position error (m)".into(),
        scale: None,
    })
    .unwrap();
    keep(&fig, "heatmap");
    let t = texts(fig.svg());
    for want in [
        "0.05",
        "0.5",
        "2",
        "no data",
        "width (m)",
        "people",
        "median position error (m)",
        "10",
    ] {
        assert!(t.iter().any(|s| s == want), "no text {want:?} in {t:?}");
    }
    let (_, _, px) = decode(&fig.png().unwrap());
    let s = ColourScale::auto([0.05, 0.5, 2.0], true);
    assert!(has_colour(&px, s.colour(2.0)) && has_colour(&px, s.colour(0.05)));
}

#[test]
fn map_draws_glass_distinctly_with_scale_bar_and_colour_bar() {
    let world = World::load(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../worlds/campus.toml"),
    )
    .unwrap();
    assert!(world.walls.iter().any(|w| w.material == "glass"));
    let pts: Vec<[f64; 2]> = (0..50).map(|k| [0.5 + k as f64 * 0.18, 2.0]).collect();
    let errors: Vec<f64> = (0..50).map(|k| 0.01 * (1.0 + k as f64)).collect();
    let fig = map_figure(&MapFigure {
        title: "corridor / mcl / seed 3".into(),
        base: MapBase::World(&world),
        paths: vec![MapPath::new("ground truth", pts.clone())],
        value_path: Some(ValuePath {
            label: "mcl estimate".into(),
            points: pts,
            values: errors.clone(),
            colour_label: "position error (m)".into(),
            scale: ColourScale::auto(errors, true),
        }),
        shapes: vec![
            MapShape::ellipse([5.0, 2.0], (0.5, 0.2), 0.3, [213, 94, 0]).label("95 % ellipse")
        ],
        ..Default::default()
    })
    .unwrap();
    keep(&fig, "map");
    let t = texts(fig.svg());
    for want in [
        "glass wall",
        "wall",
        "ground truth",
        "mcl estimate",
        "95 % ellipse",
        "x (m)",
        "y (m)",
        "position error (m)",
        "10 m",
    ] {
        assert!(t.iter().any(|s| s == want), "no text {want:?} in {t:?}");
    }
    assert!(fig.svg().contains("stroke-dasharray") || fig.svg().matches("#00AAC8").count() > 2);
    let (w, _, px) = decode(&fig.png().unwrap());
    assert_eq!(w, 1600);
    assert!(
        has_colour(&px, colour::GLASS),
        "glass is drawn in its own colour"
    );
}

#[test]
fn numbers_read_well() {
    assert_eq!(format_number(3.4641016), "3.464");
    assert_eq!(format_number(12.3), "12.3");
    assert_eq!(format_number(0.05), "0.05");
    assert_eq!(format_number(-0.0), "0");
    assert_eq!(format_number(2500.0), "2500");
    assert_eq!(
        nice_ticks(0.0, 10.0, 5),
        vec![0.0, 2.0, 4.0, 6.0, 8.0, 10.0]
    );
    assert_eq!(nice_step(0.3), 0.5);
}
