//! World generators: determinism, refusal of every bad parameter by name, glass fraction,
//! regions, access-point spacing, and that generated text passes the normal loader.

use std::path::Path;

use atrium_worlds::generate::{generate, GeneratorFile, GeneratorParams, GeneratorRegistry};
use atrium_worlds::{RegionKind, World};

fn world_of(p: &GeneratorParams) -> World {
    let text = generate(p).unwrap();
    World::from_toml_str(&text, Path::new("gen.toml")).unwrap()
}

fn region<'a>(w: &'a World, name: &str) -> &'a atrium_worlds::Region {
    w.regions
        .iter()
        .find(|r| r.name == name)
        .unwrap_or_else(|| panic!("no region {name}"))
}

/// Axis-aligned bounds of a polygon.
fn bbox(poly: &[[f64; 2]]) -> ([f64; 2], [f64; 2]) {
    let mut lo = [f64::INFINITY; 2];
    let mut hi = [f64::NEG_INFINITY; 2];
    for p in poly {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    (lo, hi)
}

#[test]
fn default_world_loads_and_is_what_was_asked() {
    let p = GeneratorParams::default();
    let w = world_of(&p);
    assert_eq!(w.name, "generated_office");
    assert!(w.walls.len() > 30, "{} walls", w.walls.len());
    assert!(w.walls.iter().any(|wl| w.is_glass(&wl.material)));
    // 20 x 16 atrium, 6 m spacing, 1.3 m margin: columns at ±3, ±9 (9 > 10 - 1.3? no: 8.7),
    // so ±3 only in x (2) and ±3 in y (2): 4 pillars.
    assert_eq!(w.pillars.len(), 4);
    for c in &w.pillars {
        assert!(w.region_at(c.center).unwrap().kind == RegionKind::Atrium);
    }
    assert!(!w.boxes.is_empty());
    assert!(!w.access_points.is_empty());
    assert!(!w.lighting.lights.is_empty());
    // 5 rooms a side, 5 corridor sections, one atrium.
    let rooms = w
        .regions
        .iter()
        .filter(|r| r.kind == RegionKind::Room)
        .count();
    assert_eq!(rooms, 10);
    let corridors = w
        .regions
        .iter()
        .filter(|r| matches!(r.kind, RegionKind::Corridor | RegionKind::GlassCorridor))
        .count();
    assert_eq!(corridors, 5);
    w.validate(Path::new("<gen>")).unwrap();
}

#[test]
fn same_seed_same_text_other_seed_other_clutter() {
    let p = GeneratorParams::default();
    let a = generate(&p).unwrap();
    let b = generate(&p.clone()).unwrap();
    assert_eq!(a, b);
    let q = GeneratorParams {
        seed: 2,
        ..p.clone()
    };
    let c = generate(&q).unwrap();
    assert_ne!(a, c);
    let (wa, wc) = (world_of(&p), world_of(&q));
    assert_ne!(wa.boxes, wc.boxes);
    // Streams are per purpose: another clutter density leaves rooms, doors and glass alone.
    let denser = GeneratorParams {
        clutter_density: 4.0,
        ..p.clone()
    };
    let wd = world_of(&denser);
    assert_eq!(wa.walls, wd.walls);
    assert!(wd.boxes.len() > wa.boxes.len());
}

/// Every parameter that cannot make a world is refused with its name as the field.
#[test]
fn bad_parameters_are_refused_by_name() {
    let d = GeneratorParams::default();
    let cases: Vec<(GeneratorParams, &str, &str)> = vec![
        (
            GeneratorParams {
                atrium_width: 30.0,
                ..d.clone()
            },
            "atrium_width",
            "wider than the floor (floor_width = 20 m)",
        ),
        (
            GeneratorParams {
                atrium_width: 1.5,
                ..d.clone()
            },
            "atrium_width",
            "narrower than the corridor",
        ),
        (
            GeneratorParams {
                corridor_width: -2.0,
                ..d.clone()
            },
            "corridor_width",
            "must be > 0, got -2",
        ),
        (
            GeneratorParams {
                floor_width: -1.0,
                ..d.clone()
            },
            "floor_width",
            "must be > 0",
        ),
        (
            GeneratorParams {
                floor_width: 5.0,
                atrium_width: 4.0,
                ..d.clone()
            },
            "floor_width",
            "too narrow",
        ),
        (
            GeneratorParams {
                corridor_length: 0.0,
                ..d.clone()
            },
            "corridor_length",
            "must be > 0",
        ),
        (
            GeneratorParams {
                atrium_length: 1e9,
                ..d.clone()
            },
            "atrium_length",
            "must be within [2, 1000]",
        ),
        (
            GeneratorParams {
                glass_fraction: 1.5,
                ..d.clone()
            },
            "glass_fraction",
            "must be within [0, 1], got 1.5",
        ),
        (
            GeneratorParams {
                glass_fraction: -0.1,
                ..d.clone()
            },
            "glass_fraction",
            "must be within [0, 1]",
        ),
        (
            GeneratorParams {
                glass_fraction: f64::NAN,
                ..d.clone()
            },
            "glass_fraction",
            "must be a finite number, got NaN",
        ),
        (
            GeneratorParams {
                atrium_width: f64::NAN,
                ..d.clone()
            },
            "atrium_width",
            "finite",
        ),
        (
            GeneratorParams {
                clutter_density: 80.0,
                ..d.clone()
            },
            "clutter_density",
            "passable",
        ),
        (
            GeneratorParams {
                clutter_density: f64::INFINITY,
                ..d.clone()
            },
            "clutter_density",
            "finite",
        ),
        (
            GeneratorParams {
                clutter_density: -1.0,
                ..d.clone()
            },
            "clutter_density",
            ">= 0",
        ),
        (
            GeneratorParams {
                room_count: 40,
                ..d.clone()
            },
            "room_count",
            "too narrow for a door",
        ),
        (
            GeneratorParams {
                door_width: 0.2,
                ..d.clone()
            },
            "door_width",
            "must be within [0.6, 10]",
        ),
        (
            GeneratorParams {
                room_width_jitter: 0.9,
                ..d.clone()
            },
            "room_width_jitter",
            "[0, 0.5]",
        ),
        (
            GeneratorParams {
                pillar_spacing: 1.0,
                ..d.clone()
            },
            "pillar_spacing",
            "robot fits between pillars",
        ),
        (
            GeneratorParams {
                pillar_spacing: -6.0,
                ..d.clone()
            },
            "pillar_spacing",
            ">= 0",
        ),
        (
            GeneratorParams {
                pillar_radius: 0.0,
                ..d.clone()
            },
            "pillar_radius",
            "must be > 0",
        ),
        (
            GeneratorParams {
                ap_spacing: 0.5,
                ..d.clone()
            },
            "ap_spacing",
            "at least 2 m",
        ),
        (
            GeneratorParams {
                ceiling_height: 50.0,
                ..d.clone()
            },
            "ceiling_height",
            "[2, 20]",
        ),
        (
            GeneratorParams {
                name: "  ".into(),
                ..d.clone()
            },
            "name",
            "must not be empty",
        ),
    ];
    for (p, param, words) in cases {
        let e = generate(&p).expect_err(param);
        assert_eq!(e.param, param, "{e:?}");
        assert!(e.msg.contains(words), "{param}: {}", e.msg);
    }
}

#[test]
fn a_floor_too_full_for_its_clutter_is_refused() {
    // Under the coverage limit, but tiny rooms and atrium cannot hold that many boxes with
    // their gaps, door approaches and the aisle: the sampler gives up and says so.
    let p = GeneratorParams {
        floor_width: 6.5,
        corridor_width: 2.0,
        corridor_length: 6.0,
        room_count: 2,
        room_width_jitter: 0.0,
        atrium_length: 3.0,
        atrium_width: 6.0,
        pillar_spacing: 0.0,
        clutter_density: 45.0,
        ..GeneratorParams::default()
    };
    let e = generate(&p).unwrap_err();
    assert_eq!(e.param, "clutter_density");
    assert!(e.msg.contains("the floor is full"), "{}", e.msg);
}

/// Walls lying along a corridor or atrium region's edge (within wall-end extensions): the
/// candidates for glass.
fn candidate_walls(w: &World) -> Vec<&atrium_worlds::Wall> {
    let edges: Vec<([f64; 2], [f64; 2])> = w
        .regions
        .iter()
        .filter(|r| r.kind != RegionKind::Room)
        .flat_map(|r| {
            let n = r.polygon.len();
            (0..n).map(move |k| (r.polygon[k], r.polygon[(k + 1) % n]))
        })
        .collect();
    let tol = 0.2;
    let on_edge = |p: [f64; 2], (a, b): ([f64; 2], [f64; 2])| {
        let (lo, hi) = bbox(&[a, b]);
        p[0] >= lo[0] - tol
            && p[0] <= hi[0] + tol
            && p[1] >= lo[1] - tol
            && p[1] <= hi[1] + tol
            && ((a[0] - b[0]).abs() < 1e-9 && (p[0] - a[0]).abs() < 1e-9
                || (a[1] - b[1]).abs() < 1e-9 && (p[1] - a[1]).abs() < 1e-9)
    };
    w.walls
        .iter()
        .filter(|wl| edges.iter().any(|&e| on_edge(wl.a, e) && on_edge(wl.b, e)))
        .collect()
}

fn len(wl: &atrium_worlds::Wall) -> f64 {
    (wl.b[0] - wl.a[0]).hypot(wl.b[1] - wl.a[1])
}

#[test]
fn glass_fraction_is_respected() {
    for (seed, fraction) in [(1, 0.0), (1, 0.1), (2, 0.3), (3, 0.5), (4, 0.77), (5, 1.0)] {
        let p = GeneratorParams {
            seed,
            glass_fraction: fraction,
            ..GeneratorParams::default()
        };
        let w = world_of(&p);
        let cand = candidate_walls(&w);
        let total: f64 = cand.iter().map(|wl| len(wl)).sum();
        let glass: f64 = cand
            .iter()
            .filter(|wl| w.is_glass(&wl.material))
            .map(|wl| len(wl))
            .sum();
        // Glass is only ever on candidate walls.
        let all_glass: f64 = w
            .walls
            .iter()
            .filter(|wl| w.is_glass(&wl.material))
            .map(len)
            .sum();
        assert!((all_glass - glass).abs() < 1e-6, "glass off the candidates");
        let measured = glass / total;
        // Tolerance: wall-end extensions at the atrium corners (0.15 m each) and 1 cm panel
        // rounding, against about 150 m of candidate wall.
        assert!(
            (measured - fraction).abs() < 0.01,
            "seed {seed}: asked {fraction}, measured {measured:.4} ({glass:.2} of {total:.2} m)"
        );
    }
}

#[test]
fn regions_are_labelled_and_cover_the_right_areas() {
    let p = GeneratorParams {
        glass_fraction: 0.6,
        ..GeneratorParams::default()
    };
    let w = world_of(&p);
    let (lc, la, fw, cw, aw) = (30.0, 20.0, 20.0, 2.0, 16.0);
    let yc = fw / 2.0;
    // Corridor sections tile the corridor exactly; each is a corridor or a glass corridor.
    let mut covered = 0.0;
    for r in w
        .regions
        .iter()
        .filter(|r| matches!(r.kind, RegionKind::Corridor | RegionKind::GlassCorridor))
    {
        let (lo, hi) = bbox(&r.polygon);
        assert!((lo[1] - (yc - cw / 2.0)).abs() < 1e-9 && (hi[1] - (yc + cw / 2.0)).abs() < 1e-9);
        assert!(lo[0] >= -1e-9 && hi[0] <= lc + 1e-9);
        covered += hi[0] - lo[0];
        // Label follows the walls: a glass corridor has at least half its side walls of
        // glass, a plain one less.
        let side: Vec<_> = w
            .walls
            .iter()
            .filter(|wl| {
                (wl.a[1] - wl.b[1]).abs() < 1e-9
                    && ((wl.a[1] - lo[1]).abs() < 1e-9 || (wl.a[1] - hi[1]).abs() < 1e-9)
                    && wl.a[0].min(wl.b[0]) >= lo[0] - 1e-9
                    && wl.a[0].max(wl.b[0]) <= hi[0] + 0.05 + 1e-9
            })
            .collect();
        let total: f64 = side.iter().map(|wl| len(wl)).sum();
        let glass: f64 = side
            .iter()
            .filter(|wl| w.is_glass(&wl.material))
            .map(|wl| len(wl))
            .sum();
        assert!(total > 0.0, "{}", r.name);
        assert_eq!(
            r.kind == RegionKind::GlassCorridor,
            glass >= 0.5 * total - 1e-9,
            "{}: {glass:.2} of {total:.2} m glass",
            r.name
        );
    }
    assert!((covered - lc).abs() < 1e-6);
    assert!(w
        .regions
        .iter()
        .any(|r| r.kind == RegionKind::GlassCorridor));
    // The atrium.
    let a = region(&w, "atrium");
    assert_eq!(a.kind, RegionKind::Atrium);
    let (lo, hi) = bbox(&a.polygon);
    assert_eq!(lo, [lc, yc - aw / 2.0]);
    assert_eq!(hi, [lc + la, yc + aw / 2.0]);
    // Points land where they should.
    assert_eq!(w.region_at([lc + la / 2.0, yc]).unwrap().name, "atrium");
    assert!(w
        .region_at([1.0, yc])
        .unwrap()
        .name
        .starts_with("corridor_"));
    assert_eq!(w.region_at([0.5, fw - 0.5]).unwrap().name, "room_n1");
    assert_eq!(w.region_at([0.5, 0.5]).unwrap().name, "room_s1");
    assert_eq!(w.region_at([lc - 0.5, 0.5]).unwrap().name, "room_s5");
    assert!(
        w.region_at([lc + 1.0, 0.5]).is_none(),
        "outside: the outline steps in"
    );
    // Rooms fill the wing beside the corridor: areas add up.
    let room_area: f64 = w
        .regions
        .iter()
        .filter(|r| r.kind == RegionKind::Room)
        .map(|r| {
            let (lo, hi) = bbox(&r.polygon);
            (hi[0] - lo[0]) * (hi[1] - lo[1])
        })
        .sum();
    assert!((room_area - lc * (fw - cw)).abs() < 1e-6, "{room_area}");
    // Every door is a gap in a corridor wall inside its room's span, wide enough.
    for side_y in [yc - cw / 2.0, yc + cw / 2.0] {
        let probe_y = if side_y > yc {
            side_y + 0.3
        } else {
            side_y - 0.3
        };
        for k in 1..=5 {
            let name = format!("room_{}{k}", if side_y > yc { "n" } else { "s" });
            let (lo, hi) = bbox(&region(&w, &name).polygon);
            // Scan the corridor wall along the room at 1 cm: the largest free run is the door.
            let mut best = 0.0f64;
            let mut run = 0.0f64;
            let mut x = lo[0] + 0.06;
            while x < hi[0] - 0.06 {
                if w.is_free([x, side_y], 0.0) {
                    run += 0.01;
                    best = best.max(run);
                } else {
                    run = 0.0;
                }
                x += 0.01;
            }
            assert!((best - 1.0).abs() < 0.03, "{name}: door {best:.2} m");
            assert!(w.region_at([0.5 * (lo[0] + hi[0]), probe_y]).unwrap().name == name);
        }
    }
}

#[test]
fn access_points_are_spaced_as_asked() {
    for spacing in [4.0, 7.5, 10.0] {
        let p = GeneratorParams {
            ap_spacing: spacing,
            ..GeneratorParams::default()
        };
        let w = world_of(&p);
        let aps = &w.access_points;
        assert!(aps.len() >= 4, "{spacing}: {}", aps.len());
        let mut at_spacing = 0;
        for (i, a) in aps.iter().enumerate() {
            let nearest = aps
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, b)| (a.position[0] - b.position[0]).hypot(a.position[1] - b.position[1]))
                .fold(f64::INFINITY, f64::min);
            assert!(nearest >= spacing - 1e-6, "{spacing}: {nearest}");
            if (nearest - spacing).abs() < 1e-6 {
                at_spacing += 1;
            }
            // Inside the building, under the ceiling.
            assert!(
                w.region_at([a.position[0], a.position[1]]).is_some() || {
                    // On a partition line between two rooms is inside too.
                    let (lo, hi) = w.bounds();
                    a.position[0] > lo[0] && a.position[0] < hi[0]
                }
            );
            assert!(a.position[2] < w.ceiling_height);
        }
        assert_eq!(
            at_spacing,
            aps.len(),
            "{spacing}: a grid, every AP has a neighbour at the spacing"
        );
    }
    let none = world_of(&GeneratorParams {
        ap_spacing: 0.0,
        ..GeneratorParams::default()
    });
    assert!(none.access_points.is_empty());
}

#[test]
fn clutter_stays_off_corridors_aisle_pillars_and_doors() {
    let p = GeneratorParams {
        clutter_density: 8.0,
        seed: 9,
        ..GeneratorParams::default()
    };
    let w = world_of(&p);
    assert!(w.boxes.len() > 40, "{}", w.boxes.len());
    let yc = 10.0;
    for b in &w.boxes {
        let r = w.region_at(b.center).expect("clutter inside a region");
        assert!(
            matches!(r.kind, RegionKind::Room | RegionKind::Atrium),
            "{}",
            r.name
        );
        for c in b.corners() {
            assert!(w.is_free(c, 0.0), "box at {:?} in a wall", b.center);
            if r.kind == RegionKind::Atrium {
                assert!(
                    (c[1] - yc).abs() > 1.0,
                    "box in the aisle at {:?}",
                    b.center
                );
            }
        }
        for pl in &w.pillars {
            assert!(b.signed_distance(pl.center) > pl.radius);
        }
    }
    // Not in the maps a localizer is given.
    let map = w.vector_map(true);
    let n_walls_and_pillars = map.segments.len();
    let bare = World {
        boxes: Vec::new(),
        ..w.clone()
    };
    assert_eq!(bare.vector_map(true).segments.len(), n_walls_and_pillars);
}

#[test]
fn generator_file_parameters_and_overrides() {
    let reg = GeneratorRegistry::with_builtins();
    let text = "generator = \"office_atrium\"\nseed = 3\natrium_width = 12.0\n";
    let mut g = GeneratorFile::parse(text, Path::new("g.toml")).unwrap();
    let w = g.generate(&reg).unwrap();
    let (lo, hi) = bbox(&region(&w, "atrium").polygon);
    assert_eq!(hi[1] - lo[1], 12.0);
    // A bad value names the parameter and its line.
    g.set_arg("atrium_width=25").unwrap();
    let e = g.generate(&reg).unwrap_err().to_string();
    assert_eq!(
        e,
        "g.toml: atrium_width: 25 m is wider than the floor (floor_width = 20 m) (from --set)"
    );
    let bad = GeneratorFile::parse(
        "generator = \"office_atrium\"\nglass_fraction = 2.0\n",
        Path::new("g.toml"),
    )
    .unwrap();
    assert_eq!(
        bad.generate(&reg).unwrap_err().to_string(),
        "g.toml: glass_fraction: must be within [0, 1], got 2 (line 2)"
    );
    // Unknown keys and mistyped values are refused naming them.
    let mut g = GeneratorFile::parse(text, Path::new("g.toml")).unwrap();
    g.set_arg("atrium_widht=20").unwrap();
    let e = g.generate(&reg).unwrap_err().to_string();
    assert!(
        e.starts_with("g.toml: atrium_widht: unknown parameter of generator \"office_atrium\""),
        "{e}"
    );
    assert!(
        e.contains("atrium_width") && e.ends_with("(from --set)"),
        "{e}"
    );
    let mut g = GeneratorFile::parse(text, Path::new("g.toml")).unwrap();
    g.set_arg("room_count=-3").unwrap();
    let e = g.generate(&reg).unwrap_err().to_string();
    assert!(e.starts_with("g.toml: room_count: "), "{e}");
    let mut g = GeneratorFile::parse(text, Path::new("g.toml")).unwrap();
    g.set_arg("corridor_width=wide").unwrap();
    let e = g.generate(&reg).unwrap_err().to_string();
    assert!(
        e.starts_with("g.toml: corridor_width: invalid type: string \"wide\""),
        "{e}"
    );
    assert!(g.set_arg("no_equals_sign").is_err());
    assert!(g.set_arg("generator=other").is_err());
    // Integers are fine where floats are expected (sweeps write `[10, 20, 30]`).
    let mut g = GeneratorFile::parse(text, Path::new("g.toml")).unwrap();
    g.set_arg("atrium_length=25").unwrap();
    g.generate(&reg).unwrap();
}

#[test]
fn generated_text_round_trips_through_the_loader() {
    for seed in 1..=5 {
        let p = GeneratorParams {
            seed,
            room_count: seed as u32 % 4,
            atrium_width: 2.0 + 3.5 * seed as f64,
            glass_fraction: 0.2 * seed as f64,
            ..GeneratorParams::default()
        };
        let text = generate(&p).unwrap();
        let w = World::from_toml_str(&text, Path::new("gen.toml")).unwrap();
        w.validate(Path::new("<gen>")).unwrap();
        // Maps can be made of it.
        assert!(w.try_occupancy_grid(0.1, false).is_ok());
    }
    // Atrium as wide as the floor, and as narrow as the corridor.
    for aw in [20.0, 2.0] {
        world_of(&GeneratorParams {
            atrium_width: aw,
            ..GeneratorParams::default()
        });
    }
}

/// The bundled generator file loads through the same path a scenario uses.
#[test]
fn bundled_generator_file_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("office_atrium_gen.toml");
    let w = atrium_worlds::load_world_or_generator(&path).unwrap();
    assert!(w.regions.iter().any(|r| r.kind == RegionKind::Atrium));
    // And an explicit world still loads through it.
    let campus = Path::new(env!("CARGO_MANIFEST_DIR")).join("campus.toml");
    assert_eq!(
        atrium_worlds::load_world_or_generator(&campus).unwrap(),
        World::campus().unwrap()
    );
}
