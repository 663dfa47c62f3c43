//! The bundled campus world: it loads, and the anchors other crates route through hold.

use std::collections::VecDeque;
use std::path::Path;

use atrium_worlds::geometry::{point_in_polygon, wall_corners};
use atrium_worlds::{Cell, RegionKind, World};

fn campus() -> World {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("campus.toml");
    let w = World::load(&path).unwrap();
    assert_eq!(w, World::campus().unwrap(), "embedded copy is the file");
    w
}

#[test]
fn campus_loads_and_validates() {
    let w = campus();
    w.validate(Path::new("campus")).unwrap();
    assert_eq!(w.name, "campus");
    assert_eq!(w.ceiling_height, 3.0);
    assert_eq!(w.bounds(), ([-0.15, -0.15], [60.15, 40.15]));
    let rooms = w
        .regions
        .iter()
        .filter(|r| r.kind == RegionKind::Room)
        .count();
    assert_eq!(rooms, 17);
}

#[test]
fn atrium_is_large_and_empty() {
    let w = campus();
    let atrium = w.regions.iter().find(|r| r.name == "atrium").unwrap();
    assert_eq!(atrium.kind, RegionKind::Atrium);
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for p in &atrium.polygon {
        for k in 0..2 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    assert!(hi[0] - lo[0] >= 25.0 && hi[1] - lo[1] >= 20.0);
    // Nearest solid to (45, 21): the east wall's face x = 59.85, 14.85 m away.
    assert!((w.clearance([45.0, 21.0]) - 14.85).abs() < 1e-9);
    assert!(w.clearance([45.0, 21.0]) > 8.0);
}

#[test]
fn glass_corridor_north_wall_is_glass_with_a_door() {
    let w = campus();
    let mut x = 30.25;
    while x < 59.8 {
        let p = [x, 2.85];
        let holders: Vec<_> = w
            .walls
            .iter()
            .filter(|wall| point_in_polygon(p, &wall_corners(wall.a, wall.b, wall.thickness)))
            .collect();
        if (55.0..=57.0).contains(&x) {
            assert!(holders.is_empty(), "door at x = {x}");
        } else {
            assert!(!holders.is_empty(), "no wall at x = {x}");
            assert!(holders.iter().all(|h| w.is_glass(&h.material)), "x = {x}");
            assert_eq!(holders[0].thickness, 0.05);
        }
        x += 0.1;
    }
    // The door is 2 m wide: 1 m from its centre to each glass post.
    assert!((w.clearance([56.0, 2.85]) - 1.0).abs() < 1e-9);
    // West of x = 30 the same wall is drywall.
    let west = w
        .walls
        .iter()
        .find(|wall| point_in_polygon([15.5, 2.85], &wall_corners(wall.a, wall.b, wall.thickness)))
        .unwrap();
    assert_eq!(west.material, "drywall");
}

#[test]
fn anchor_points_are_free_and_named() {
    let w = campus();
    for (p, name) in [
        ([20.0, 20.0], "office_corridor"),
        ([10.0, 30.0], "west_corridor"),
        ([20.0, 1.5], "south_corridor"),
        ([45.0, 1.5], "glass_corridor"),
        ([45.0, 21.0], "atrium"),
        ([10.0, 20.0], "office_corridor"),
    ] {
        assert!(w.is_free(p, 0.4), "{p:?} must be free for a 0.4 m robot");
        assert_eq!(w.region_at(p).map(|r| r.name.as_str()), Some(name), "{p:?}");
    }
}

/// Clearance along a drivable centreline never drops below `min`.
fn assert_centreline(w: &World, from: [f64; 2], to: [f64; 2], min: f64) {
    for k in 0..=1000 {
        let t = k as f64 / 1000.0;
        let p = [
            from[0] + t * (to[0] - from[0]),
            from[1] + t * (to[1] - from[1]),
        ];
        let c = w.clearance(p);
        assert!(c >= min - 1e-9, "clearance {c} at {p:?} below {min}");
    }
}

#[test]
fn corridor_centrelines_keep_their_clear_widths() {
    let w = campus();
    // Office corridor: clear y ∈ [19, 21], so 1 m either side of y = 20.
    assert_centreline(&w, [1.15, 20.0], [29.0, 20.0], 1.0);
    // Its west end x = 1 is 0.85 m from the outer wall's face x = 0.15.
    assert!((w.clearance([1.0, 20.0]) - 0.85).abs() < 1e-9);
    // Its walls' faces are exactly there.
    assert!((w.clearance([2.0, 20.0]) - 1.0).abs() < 1e-9);
    // West corridor: clear x ∈ [9, 11], from the south corridor to the north wall.
    assert_centreline(&w, [10.0, 1.5], [10.0, 38.5], 1.0);
    assert!((w.clearance([10.0, 35.0]) - 1.0).abs() < 1e-9);
    // South and glass corridor: clear y ∈ [0.15, 2.8]; y = 1.5 is 1.3 m from the drywall.
    assert_centreline(&w, [1.5, 1.5], [58.5, 1.5], 1.3);
    assert!((w.clearance([20.0, 1.5]) - 1.3).abs() < 1e-9);
    // Into the atrium through the 2 m opening.
    assert_centreline(&w, [29.0, 20.0], [35.0, 20.0], 1.0);
}

#[test]
fn regions_cover_the_floor() {
    let w = campus();
    // An offset lattice never lands on a centre line, where regions meet.
    let mut x = 0.13;
    while x < 60.0 {
        let mut y = 0.11;
        while y < 40.0 {
            assert!(w.region_at([x, y]).is_some(), "no region at ({x}, {y})");
            y += 0.37;
        }
        x += 0.41;
    }
}

#[test]
fn every_room_is_reachable_from_the_office_corridor() {
    // Flood fill over 0.1 m cells whose centre keeps a 0.3 m robot clear of every solid.
    let w = campus();
    let g = w.occupancy_grid(0.1, true);
    let ok: Vec<bool> = (0..g.height)
        .flat_map(|j| (0..g.width).map(move |i| (i, j)))
        .map(|(i, j)| w.is_free(g.cell_center(i, j), 0.3))
        .collect();
    let mut reached = vec![false; ok.len()];
    let start = g.world_to_cell([20.0, 20.0]).unwrap();
    let mut queue = VecDeque::from([start]);
    reached[g.index(start.0, start.1)] = true;
    while let Some((i, j)) = queue.pop_front() {
        let neighbours = [
            (i.wrapping_sub(1), j),
            (i + 1, j),
            (i, j.wrapping_sub(1)),
            (i, j + 1),
        ];
        for (a, b) in neighbours {
            if a < g.width && b < g.height {
                let k = g.index(a, b);
                if ok[k] && !reached[k] {
                    reached[k] = true;
                    queue.push_back((a, b));
                }
            }
        }
    }
    for region in &w.regions {
        let any = (0..g.height).any(|j| {
            (0..g.width).any(|i| {
                reached[g.index(i, j)] && point_in_polygon(g.cell_center(i, j), &region.polygon)
            })
        });
        assert!(any, "region {} cannot be reached", region.name);
    }
    // Nothing leaks outside the building.
    for j in 0..g.height {
        for i in 0..g.width {
            if reached[g.index(i, j)] {
                let c = g.cell_center(i, j);
                assert!(
                    c[0] > 0.15 && c[0] < 59.85 && c[1] > 0.15 && c[1] < 39.85,
                    "{c:?}"
                );
            }
        }
    }
}

#[test]
fn vector_maps_differ_by_the_glass_walls() {
    let w = campus();
    let with = w.vector_map(true);
    let without = w.vector_map(false);
    let glass_walls: Vec<_> = w.walls.iter().filter(|x| w.is_glass(&x.material)).collect();
    assert_eq!(glass_walls.len(), 2);
    assert_eq!(
        with.segments.len(),
        4 * w.walls.len() + 16 * w.pillars.len()
    );
    assert_eq!(
        with.segments.len() - without.segments.len(),
        4 * glass_walls.len()
    );
    for s in &without.segments {
        assert!(with.segments.contains(s));
    }
    // Every extra segment is an edge of a glass wall's footprint.
    for s in with
        .segments
        .iter()
        .filter(|s| !without.segments.contains(s))
    {
        let on_glass = glass_walls.iter().any(|g| {
            let c = wall_corners(g.a, g.b, g.thickness);
            (0..4).any(|k| s.a == c[k] && s.b == c[(k + 1) % 4])
        });
        assert!(on_glass, "{s:?}");
    }
}

#[test]
fn occupancy_grid_agrees_with_is_free_and_shows_thin_glass() {
    let w = campus();
    let g = w.occupancy_grid(0.1, true);
    // Bounds 60.3 × 40.3 m plus 1 m each side, at 0.1 m.
    assert_eq!((g.width, g.height), (623, 423));
    for j in 0..g.height {
        for i in 0..g.width {
            let c = g.cell_center(i, j);
            let cell = g.cells[g.index(i, j)];
            assert_ne!(cell, Cell::Unknown);
            if cell == Cell::Free {
                assert!(w.is_free(c, 0.0), "free cell {c:?} inside a solid");
            }
            if !w.is_free(c, 0.0) {
                assert_eq!(cell, Cell::Occupied, "{c:?}");
            }
        }
    }
    // The 0.05 m glass wall appears in the 0.1 m grid along its length, not in the door, and
    // not at all when glass is left out.
    let no_glass = w.occupancy_grid(0.1, false);
    for k in 0..290 {
        let x = 30.52 + 0.1 * k as f64;
        // Cells within one cell of the door posts may hold a post's end: skip them.
        if (54.9..55.1).contains(&x) || (56.9..57.1).contains(&x) {
            continue;
        }
        let door = (55.0..=57.0).contains(&x);
        let expect = if door { Cell::Free } else { Cell::Occupied };
        assert_eq!(g.at([x, 2.85]), expect, "x = {x}");
        assert_eq!(no_glass.at([x, 2.85]), Cell::Free, "x = {x}");
    }
    assert_eq!(g.at([-5.0, 5.0]), Cell::Unknown);
}

#[test]
fn campus_pgm_and_yaml() {
    let w = campus();
    let g = w.occupancy_grid(0.05, false);
    let pgm = g.to_pgm();
    let header = format!("P5\n{} {}\n255\n", g.width, g.height);
    assert!(pgm.starts_with(header.as_bytes()));
    let pixels = &pgm[header.len()..];
    assert_eq!(pixels.len(), g.width * g.height);
    assert!(pixels.iter().all(|&v| v == 0 || v == 254));
    // The first image row is the top (largest y) margin: free.
    assert!(pixels[..g.width].iter().all(|&v| v == 254));
    // Bottom-left pixel of the building's south-west corner row: the row holding y = 0.
    let (_, j) = g.world_to_cell([0.0, 0.0]).unwrap();
    let row = g.height - 1 - j;
    let (i, _) = g.world_to_cell([0.0, 0.0]).unwrap();
    assert_eq!(pixels[row * g.width + i], 0);
    let yaml = g.ros_yaml("campus.pgm");
    assert!(yaml.contains("image: \"campus.pgm\"\n"));
    assert!(yaml.contains("resolution: 0.05\n"));
    assert!(yaml.contains("mode: trinary\n"));
}
