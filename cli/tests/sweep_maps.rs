//! Sweep pictures and per-location error maps (issue 9, items 2 and 3): heat maps have the
//! right size and put hotter colours on larger errors; error maps are byte-identical whether a
//! sweep runs whole, in shards merged afterwards, or resumed; and the reduced campus map has
//! the shape of 004 §3 Figure 2 where the physics gives it robustly.

mod common;

use atrium_experiments::sweep::csv::{Results, Row};
use atrium_experiments::sweep::heatmap::{self, AxisLabels};
use atrium_experiments::sweep::{self, Sweep, SweepSettings};
use atrium_localization::error_map::ErrorMap;
use atrium_scenarios::figure::ColourScale;
use common::{atrium, tmpdir};
use std::path::{Path, PathBuf};

fn row(cell: usize, trial: usize, loc: &str, median: f64) -> Row {
    let mut values: Vec<String> = vec![String::new(); 9];
    values[1] = median.to_string();
    Row {
        params: vec![],
        cell,
        trial,
        seed: 0,
        localizer: loc.into(),
        values,
    }
}

fn axis(path: &str, values: &[&str]) -> AxisLabels {
    AxisLabels {
        path: path.into(),
        values: values.iter().map(|s| s.to_string()).collect(),
    }
}

#[test]
fn heat_maps_have_one_cell_per_axis_value_and_hotter_is_larger() {
    // 2 × 2 × 2 cells (last axis fastest); trial medians per cell: cell c has 0.1·(c+1) m,
    // except that cell 3 (x = 1, y = 1 of slice 1) is 5 m.
    let axes = vec![
        axis("a", &["1", "2"]),
        axis("b", &["x", "y"]),
        axis("c", &["p", "q"]),
    ];
    let mut rows = Vec::new();
    for cell in 0..8 {
        let m = if cell == 7 {
            5.0
        } else {
            0.1 * (cell + 1) as f64
        };
        for t in 0..3 {
            // Median over trials of per-trial medians: m (trials at m - 0.01, m, m + 0.01).
            rows.push(row(cell, t, "mcl", m + 0.01 * (t as f64 - 1.0)));
        }
    }
    let results = Results {
        hash: "h".into(),
        name: "t".into(),
        axis_paths: vec!["a".into(), "b".into(), "c".into()],
        rows,
        layout: None,
        dropped_partial: false,
    };
    let pics = heatmap::heatmaps(&results, &axes).unwrap().pictures;
    let names: Vec<&str> = pics.iter().map(|(n, _)| n.as_str()).collect();
    assert_eq!(names, ["heatmap_mcl_c=p", "heatmap_mcl_c=q"]);
    let q = &pics[1].1;
    assert_eq!(
        q.title(),
        heatmap::title("t", "mcl", &["c = q".to_string()])
    );
    assert!(q.size().0 >= 1600);
    // Slice c = q holds cells 1, 3, 5, 7: (a, b) = (1,x), (1,y), (2,x), (2,y), medians
    // 0.2, 0.4, 0.6 and 5 m: the largest is the brightest viridis colour, the smallest the
    // darkest, and each cell carries its value as text.
    let cells = big_rects(q.svg());
    let s = ColourScale::auto([0.2, 5.0], true);
    assert!(
        cells.contains(&hex(s.colour(5.0))),
        "largest error: brightest colour"
    );
    assert!(
        cells.contains(&hex(s.colour(0.2))),
        "smallest error: darkest colour"
    );
    assert!(cells.contains(&hex(s.colour(0.6))));
    for v in [
        "0.2",
        "0.4",
        "0.6",
        "5",
        "median position error (m)",
        "a",
        "b",
    ] {
        assert!(
            q.svg().contains(&format!("\n{v}\n</text>")),
            "no text {v:?}"
        );
    }

    // One axis: a strip one cell high, a cell without results grey and marked.
    let strip = vec![axis("a", &["1", "2", "3"])];
    let r1 = Results {
        axis_paths: vec!["a".into()],
        rows: vec![row(0, 0, "w", 1.0), row(2, 0, "w", 2.0)],
        ..results
    };
    let pics = heatmap::heatmaps(&r1, &strip).unwrap().pictures;
    assert_eq!(pics.len(), 1);
    let svg = pics[0].1.svg();
    assert!(
        big_rects(svg).contains(&"#E1E1E1".to_string()),
        "a cell without results is grey"
    );
    assert!(svg.contains("no data"));
    let s = ColourScale::auto([1.0, 2.0], true);
    assert!(big_rects(svg).contains(&hex(s.colour(2.0))));
}

fn hex(c: [u8; 3]) -> String {
    format!("#{:02X}{:02X}{:02X}", c[0], c[1], c[2])
}

/// Fill colours of the SVG's filled rectangles taller than 20 units (cells, not the colour
/// bar's one-unit stripes).
fn big_rects(svg: &str) -> Vec<String> {
    svg.split("<rect")
        .skip(1)
        .filter_map(|r| {
            let attr = |name: &str| {
                let k = r.find(&format!(" {name}=\""))? + name.len() + 3;
                Some(r[k..k + r[k..].find('"')?].to_string())
            };
            let h: f64 = attr("height")?.parse().ok()?;
            (h > 20.0).then(|| attr("fill")).flatten()
        })
        .collect()
}

fn data(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(name)
}

fn settings(out: &Path, shard: Option<(usize, usize)>, resume: bool) -> SweepSettings {
    SweepSettings {
        out: out.to_path_buf(),
        jobs: Some(1),
        shard,
        resume,
        progress: false,
    }
}

/// Sample-weighted mean error of `layer` over the visited cells whose centre satisfies `keep`.
fn mean_where(map: &ErrorMap, layer: usize, keep: impl Fn([f64; 2]) -> bool) -> f64 {
    let (mut sum, mut n) = (0.0, 0u32);
    for j in 0..map.height {
        for i in 0..map.width {
            if let Some((m, k)) = map.mean(layer, i, j) {
                if keep(map.cell_centre(i, j)) {
                    sum += m * k as f64;
                    n += k;
                }
            }
        }
    }
    assert!(n > 0, "no samples in the region");
    sum / n as f64
}

#[test]
fn error_maps_agree_across_shards_and_resume_and_show_figure_2() {
    let d = tmpdir("errmap");
    let s = Sweep::load(&data("error_map_small_sweep.toml")).unwrap();
    assert_eq!(s.error_map, Some(4.0));
    let whole = d.join("whole");
    let o = sweep::run_sweep(&s, &settings(&whole, None, false)).unwrap();
    assert_eq!(o.ran, 2);
    for f in [
        "error_map.csv",
        "error_map_laser.png",
        "error_map_wifi.png",
        "error_map_best.png",
        "error_map_best.svg",
        "error_map_laser.svg",
        "heatmap_laser.png",
        "heatmap_laser.svg",
        "maps/c0_t0.csv",
        "maps/c0_t1.csv",
    ] {
        assert!(whole.join(f).is_file(), "{f} missing");
    }
    let png = std::fs::read(whole.join("error_map_best.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let svg = std::fs::read_to_string(whole.join("error_map_laser.svg")).unwrap();
    assert!(svg.contains("mean position error (m)") && svg.contains("x (m)"));

    let (s0, s1, merged) = (d.join("s0"), d.join("s1"), d.join("merged"));
    sweep::run_sweep(&s, &settings(&s0, Some((0, 2)), false)).unwrap();
    sweep::run_sweep(&s, &settings(&s1, Some((1, 2)), false)).unwrap();
    sweep::merge(&merged, &[&s0, &s1]).unwrap();
    // The first shard's folder, resumed as a whole sweep: it runs only the missing trial.
    let o = sweep::run_sweep(&s, &settings(&s0, None, true)).unwrap();
    assert_eq!((o.ran, o.skipped), (1, 1));

    let text = |dir: &Path| std::fs::read_to_string(dir.join("error_map.csv")).unwrap();
    let reference = text(&whole);
    assert_eq!(text(&merged), reference, "merged shards");
    assert_eq!(text(&s0), reference, "resumed");
    assert!(merged.join("error_map_wifi.png").is_file());
    // A shard's own map holds only its trials.
    assert_ne!(text(&s1), reference);

    // Figure 2's shape: in the office corridor (x < 30) the laser's mean error is below
    // WiFi's, by an order of magnitude; in the atrium's open interior, where every wall is
    // beyond the laser's 8 m, it is not.
    let map = ErrorMap::from_csv(&reference).unwrap();
    let (laser, wifi) = (
        map.localizer_index("laser").unwrap(),
        map.localizer_index("wifi").unwrap(),
    );
    let corridor = |p: [f64; 2]| p[0] < 30.0;
    let interior = |p: [f64; 2]| (38.0..=52.0).contains(&p[0]) && (10.85..=32.0).contains(&p[1]);
    let (lc, wc) = (
        mean_where(&map, laser, corridor),
        mean_where(&map, wifi, corridor),
    );
    let (li, wi) = (
        mean_where(&map, laser, interior),
        mean_where(&map, wifi, interior),
    );
    assert!(
        lc < 0.1 && lc * 5.0 < wc,
        "corridor: laser {lc} m, wifi {wc} m"
    );
    assert!(li > wi, "open interior: laser {li} m, wifi {wi} m");
    std::fs::remove_dir_all(&d).unwrap();
}

#[test]
fn bad_error_map_and_bench_input_exit_2() {
    let d = tmpdir("errmap-bad");
    let f = d.join("bad.toml");
    let base = atrium_scenarios::bundled_scenarios_dir().join("corridor_tracking.toml");
    std::fs::write(
        &f,
        format!(
            "base = {:?}\nseed = 1\ntrials = 1\n[error_map]\nresolution = 0.0\n",
            base.to_str().unwrap()
        ),
    )
    .unwrap();
    let out = d.join("o");
    let o = atrium(&["sweep", f.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("error_map.resolution"), "{err}");
    std::fs::write(
        &f,
        format!(
            "base = {:?}\nseed = 1\ntrials = 1\n[error_map]\nresolution = 1.0\ncells = 3\n",
            base.to_str().unwrap()
        ),
    )
    .unwrap();
    let o = atrium(&["sweep", f.to_str().unwrap(), "--out", out.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("cells"));

    let o = atrium(&["bench", "sweep"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("sweep file"));
    let o = atrium(&["bench", "sweep", d.join("missing.toml").to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("missing.toml"));
    std::fs::write(
        &f,
        format!(
            "base = {:?}\nseed = 1\ntrials = 1\n[axes]\nduration_s = [0.1]\n",
            base.to_str().unwrap()
        ),
    )
    .unwrap();
    let o = atrium(&["bench", "sweep", f.to_str().unwrap(), "--trials", "0"]);
    assert_eq!(o.status.code(), Some(2));
    std::fs::remove_dir_all(&d).unwrap();
}
