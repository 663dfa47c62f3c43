//! Pedestrians: people who walk between random goals in the free floor at walking speed, as
//! rapier colliders that every sensor ray sees and nothing pushes. They live in the scene
//! only, never in the `World`, so no map a localizer is given knows them.
//!
//! Each person is a cylinder collider without a body (a [`PersonShape`], which rays meet in
//! closed form rather than by parry's GJK), moved by [`People::place`]. Rays are all that
//! see a person, so a person's collider need only be where they are when something casts:
//! the simulation places people before every physics step, or only before the steps after
//! which its own sensors cast (`PeoplePlacement`). The positions [`People::step`] advances
//! are current at every step either way. Kinematic bodies moved every step cost rapier a
//! support-point bounding box per person per step; placed at a 10 Hz scan rate instead, a
//! twentieth of that.
//!
//! Where people may walk is a coarse grid over the world's bounds: a cell is walkable when a
//! person standing anywhere in it clears every wall, pillar and box (the obstacle test is
//! inflated by the cell's half diagonal and the sampling step below), and lies in the largest
//! connected walkable region of the floor the robot starts on. A person walks a straight
//! segment to a goal only if every sample along it falls in walkable cells, so no person ever
//! enters a wall; a grid planner would buy longer walks in mazes, not safety.
//!
//! People keep clear of the robot: a step that would bring a person within
//! [`ROBOT_MARGIN`] of the robot's footprint, and closer than before, is not taken; the person
//! waits, and after [`PATIENCE_S`] of waiting yields by choosing a new goal. That breaks the
//! one deadlock the robot's own stopping rule (`controller.rs`) could make: a robot waiting
//! for a person who waits for the robot. People pass through each other (they are few, and
//! crowd dynamics are not what a localizer is tested on).

use crate::error::SimError;
use crate::person_shape::PersonShape;
use crate::scene::{vec3, Scene, PEOPLE_GROUP};
use atrium_robots::Pose2;
use atrium_worlds::World;
use rand::Rng;
use rand_chacha::ChaCha8Rng;
use rapier3d::prelude::*;
use serde::{Deserialize, Serialize};

/// How many people there are, how fast they walk and how big they are (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PeopleParams {
    /// People per 100 m² of free floor (the floor reachable from the robot's start, outside
    /// every obstacle); 0 = nobody, and then nothing about a run changes.
    pub density: f64,
    /// Walking speed, m/s.
    pub speed: f64,
    /// Radius of a person's cylinder, m.
    pub radius: f64,
    /// Height of a person's cylinder, m.
    pub height: f64,
}

impl Default for PeopleParams {
    fn default() -> Self {
        Self {
            density: 0.0,
            speed: 1.2,
            radius: 0.25,
            height: 1.7,
        }
    }
}

/// The largest fraction of free floor people's discs may cover: beyond a third, people can
/// no longer walk between each other and the robot (a standing crowd, not pedestrians).
pub const MAX_COVERED_FRACTION: f64 = 1.0 / 3.0;
/// The fastest walking speed accepted, m/s (a sprint; faster is a unit mistake).
pub const MAX_SPEED_M_S: f64 = 10.0;
/// The largest person accepted, m (radius): larger discs fit no corridor.
pub const MAX_RADIUS_M: f64 = 2.0;

impl PeopleParams {
    /// Density finite and >= 0 and not filling the floor ([`MAX_COVERED_FRACTION`]); speed,
    /// radius and height finite and > 0. Errors name `people.<field>`.
    pub fn validate(&self) -> Result<(), SimError> {
        if !(self.density.is_finite() && self.density >= 0.0) {
            return Err(SimError::config(
                "people.density",
                format!(
                    "must be a finite number of people per 100 m² >= 0, got {}",
                    self.density
                ),
            ));
        }
        for (f, v, max) in [
            ("people.speed", self.speed, MAX_SPEED_M_S),
            ("people.radius", self.radius, MAX_RADIUS_M),
            ("people.height", self.height, f64::INFINITY),
        ] {
            crate::error::positive(f, v)?;
            if v > max {
                return Err(SimError::config(
                    f,
                    format!("{v} is above the limit of {max}"),
                ));
            }
        }
        let covered = self.covered_fraction();
        if covered > MAX_COVERED_FRACTION {
            return Err(SimError::config(
                "people.density",
                format!(
                    "{} people per 100 m² of radius {} m would cover {:.0} % of the free floor; \
                     at most {:.0} % is allowed (density <= {:.1})",
                    self.density,
                    self.radius,
                    100.0 * covered,
                    100.0 * MAX_COVERED_FRACTION,
                    MAX_COVERED_FRACTION * 100.0 / (std::f64::consts::PI * self.radius.powi(2))
                ),
            ));
        }
        Ok(())
    }

    /// Fraction of the free floor the people's discs cover.
    pub fn covered_fraction(&self) -> f64 {
        self.density * std::f64::consts::PI * self.radius * self.radius / 100.0
    }
}

/// Grid cell size, m: fine enough for 1 m doors, coarse enough to build in milliseconds.
const CELL: f64 = 0.2;
/// Samples along a walk segment per cell.
const SAMPLES_PER_CELL: f64 = 4.0;
/// How close a person comes to the robot's footprint, m.
pub const ROBOT_MARGIN: f64 = 0.3;
/// How long a person waits for the robot before choosing another goal, s.
pub const PATIENCE_S: f64 = 3.0;
/// People start at least this far from the robot's footprint, m.
const START_CLEARANCE: f64 = 1.0;
/// Random goals tried before falling back to a neighbouring cell.
const GOAL_TRIES: usize = 30;
/// A goal closer than this is not worth a walk, m.
const MIN_WALK: f64 = 1.0;

/// What a person's collider filters on: a group no collider belongs to, so people form no
/// contact pairs with anything (not even each other) and cost the physics step nothing
/// beyond their broad-phase updates; sensor queries (member of every group) still see them.
const NOBODY_GROUP: Group = Group::GROUP_32;
/// People float this far above the floor, m: clear of the floor slab's bounding box, so the
/// broad phase never pairs them with it; far below any sensor ray that matters.
const FLOAT: f64 = 0.02;

/// `user_data` of a person's collider: not a static tag (`scene::decode_tag` gives `None`),
/// so sensors treat people as opaque and uncoloured.
const PERSON_TAG: u128 = 0x10;

/// Whether a collider's `user_data` marks a person.
pub fn is_person(user_data: u128) -> bool {
    user_data & 0xff == PERSON_TAG
}

/// Where people may stand: see the module docs.
#[derive(Debug, Clone)]
struct WalkGrid {
    origin: [f64; 2],
    nx: usize,
    ny: usize,
    walkable: Vec<bool>,
    /// Indices of walkable cells (random goals are drawn from these).
    cells: Vec<usize>,
    /// Free floor connected to the start, m².
    floor_area: f64,
}

fn segment_distance(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p[0] - a[0] - t * dx).hypot(p[1] - a[1] - t * dy)
}

impl WalkGrid {
    fn new(world: &World, radius: f64, start: [f64; 2]) -> WalkGrid {
        let (lo, hi) = world.bounds();
        let (lo, hi) = if lo[0].is_finite() && hi[0].is_finite() {
            (lo, hi)
        } else {
            (
                [start[0] - 10.0, start[1] - 10.0],
                [start[0] + 10.0, start[1] + 10.0],
            )
        };
        let origin = [lo[0] - CELL, lo[1] - CELL];
        let nx = ((hi[0] - origin[0]) / CELL).ceil() as usize + 2;
        let ny = ((hi[1] - origin[1]) / CELL).ceil() as usize + 2;
        // Any point of a cell is within the half diagonal of its centre, and a sample misses
        // at most half a sampling step of a segment.
        let inflation =
            radius + CELL * std::f64::consts::FRAC_1_SQRT_2 + 0.5 * CELL / SAMPLES_PER_CELL;
        let mut clearance = vec![f64::INFINITY; nx * ny];
        let centre = |i: usize, j: usize| {
            [
                origin[0] + (i as f64 + 0.5) * CELL,
                origin[1] + (j as f64 + 0.5) * CELL,
            ]
        };
        // Rasterise each obstacle over its inflated bounding box only.
        let mut stamp = |blo: [f64; 2], bhi: [f64; 2], dist: &dyn Fn([f64; 2]) -> f64| {
            let i0 = (((blo[0] - inflation - origin[0]) / CELL).floor().max(0.0)) as usize;
            let j0 = (((blo[1] - inflation - origin[1]) / CELL).floor().max(0.0)) as usize;
            let i1 = (((bhi[0] + inflation - origin[0]) / CELL).ceil() as usize).min(nx - 1);
            let j1 = (((bhi[1] + inflation - origin[1]) / CELL).ceil() as usize).min(ny - 1);
            for j in j0..=j1 {
                for i in i0..=i1 {
                    let c = &mut clearance[j * nx + i];
                    *c = c.min(dist(centre(i, j)));
                }
            }
        };
        for w in &world.walls {
            let h = 0.5 * w.thickness;
            let blo = [w.a[0].min(w.b[0]) - h, w.a[1].min(w.b[1]) - h];
            let bhi = [w.a[0].max(w.b[0]) + h, w.a[1].max(w.b[1]) + h];
            stamp(blo, bhi, &|p| segment_distance(p, w.a, w.b) - h);
        }
        for p in &world.pillars {
            let r = p.radius;
            let (c, blo, bhi) = (
                p.center,
                [p.center[0] - r, p.center[1] - r],
                [p.center[0] + r, p.center[1] + r],
            );
            stamp(blo, bhi, &|q| (q[0] - c[0]).hypot(q[1] - c[1]) - r);
        }
        for b in &world.boxes {
            let r = 0.5 * b.size[0].hypot(b.size[1]);
            let blo = [b.center[0] - r, b.center[1] - r];
            let bhi = [b.center[0] + r, b.center[1] + r];
            stamp(blo, bhi, &|q| b.signed_distance(q));
        }

        let cell_of = |p: [f64; 2]| {
            let i = ((p[0] - origin[0]) / CELL).floor();
            let j = ((p[1] - origin[1]) / CELL).floor();
            (i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny)
                .then(|| j as usize * nx + i as usize)
        };
        let flood = |seed: usize, open: &dyn Fn(usize) -> bool, mark: &mut Vec<u32>, label: u32| {
            let mut stack = vec![seed];
            mark[seed] = label;
            let mut n = 0usize;
            while let Some(c) = stack.pop() {
                n += 1;
                let (i, j) = (c % nx, c / nx);
                let mut push = |d: usize| {
                    if mark[d] == 0 && open(d) {
                        mark[d] = label;
                        stack.push(d);
                    }
                };
                if i > 0 {
                    push(c - 1);
                }
                if i + 1 < nx {
                    push(c + 1);
                }
                if j > 0 {
                    push(c - nx);
                }
                if j + 1 < ny {
                    push(c + nx);
                }
            }
            n
        };

        // The floor the robot starts on: cells whose centre is outside every obstacle,
        // connected to the start's cell.
        let mut floor = vec![0u32; nx * ny];
        let floor_cells = match cell_of(start) {
            Some(s) if clearance[s] > 0.0 => flood(s, &|c| clearance[c] > 0.0, &mut floor, 1),
            _ => 0,
        };
        // The largest connected region of walkable cells on that floor.
        let open = |c: usize| floor[c] == 1 && clearance[c] > inflation;
        let mut label = vec![0u32; nx * ny];
        let (mut best, mut best_n, mut next) = (0u32, 0usize, 1u32);
        for c in 0..nx * ny {
            if label[c] == 0 && open(c) {
                let n = flood(c, &open, &mut label, next);
                if n > best_n {
                    (best, best_n) = (next, n);
                }
                next += 1;
            }
        }
        let walkable: Vec<bool> = label.iter().map(|&l| l != 0 && l == best).collect();
        let cells = (0..nx * ny).filter(|&c| walkable[c]).collect();
        WalkGrid {
            origin,
            nx,
            ny,
            walkable,
            cells,
            floor_area: floor_cells as f64 * CELL * CELL,
        }
    }

    fn cell_of(&self, p: [f64; 2]) -> Option<usize> {
        let i = ((p[0] - self.origin[0]) / CELL).floor();
        let j = ((p[1] - self.origin[1]) / CELL).floor();
        (i >= 0.0 && j >= 0.0 && (i as usize) < self.nx && (j as usize) < self.ny)
            .then(|| j as usize * self.nx + i as usize)
    }

    fn centre(&self, c: usize) -> [f64; 2] {
        [
            self.origin[0] + ((c % self.nx) as f64 + 0.5) * CELL,
            self.origin[1] + ((c / self.nx) as f64 + 0.5) * CELL,
        ]
    }

    fn walkable_at(&self, p: [f64; 2]) -> bool {
        self.cell_of(p).is_some_and(|c| self.walkable[c])
    }

    /// Every sample along `a -> b` lies in a walkable cell.
    fn clear(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        let len = (b[0] - a[0]).hypot(b[1] - a[1]);
        let n = (len * SAMPLES_PER_CELL / CELL).ceil().max(1.0) as usize;
        (0..=n).all(|k| {
            let t = k as f64 / n as f64;
            self.walkable_at([a[0] + t * (b[0] - a[0]), a[1] + t * (b[1] - a[1])])
        })
    }
}

/// One pedestrian.
#[derive(Debug, Clone)]
struct Person {
    pos: [f64; 2],
    goal: [f64; 2],
    /// Seconds spent waiting for the robot.
    waited: f64,
    collider: ColliderHandle,
    /// Whether the collider stands at `pos`.
    placed: bool,
}

/// The people of a run and the random stream that moves them.
#[derive(Debug, Clone)]
pub struct People {
    params: PeopleParams,
    grid: WalkGrid,
    people: Vec<Person>,
    positions: Vec<[f64; 2]>,
    rng: ChaCha8Rng,
    /// Robot footprint in the base frame (min, max corners), m.
    footprint: ([f64; 2], [f64; 2]),
}

/// When the simulation moves people's colliders to where they walked (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PeoplePlacement {
    /// Before every physics step: the scene is current after every step, for callers that
    /// cast rays of their own between the simulation's sensor readings.
    #[default]
    EveryStep,
    /// Only before the steps after which one of the simulation's own sensors reads the scene:
    /// those readings are exactly the `EveryStep` ones, at a fraction of the cost.
    SensorInstants,
}

/// Where a person's collider stands: the cylinder's centre, floating just above the floor.
fn person_translation(pos: [f64; 2], height: f64) -> Vector {
    vec3(pos[0], pos[1], FLOAT + 0.5 * height)
}

/// Distance from `p` (world frame) to the robot's footprint box with the base at `robot`.
pub fn footprint_distance(p: [f64; 2], robot: &Pose2, footprint: ([f64; 2], [f64; 2])) -> f64 {
    let (dx, dy) = (p[0] - robot.x, p[1] - robot.y);
    let (s, c) = robot.theta.sin_cos();
    let local = [c * dx + s * dy, -s * dx + c * dy];
    let (lo, hi) = footprint;
    let ex = (lo[0] - local[0]).max(local[0] - hi[0]).max(0.0);
    let ey = (lo[1] - local[1]).max(local[1] - hi[1]).max(0.0);
    ex.hypot(ey)
}

impl People {
    /// Places `round(density · free floor / 100)` people in `scene` at random walkable
    /// spots clear of the robot (footprint box `footprint` at `start`), each with a goal.
    pub fn new(
        world: &World,
        scene: &mut Scene,
        params: PeopleParams,
        start: Pose2,
        footprint: ([f64; 2], [f64; 2]),
        rng: ChaCha8Rng,
    ) -> Result<People, SimError> {
        params.validate()?;
        let grid = WalkGrid::new(world, params.radius, [start.x, start.y]);
        let n = (params.density * grid.floor_area / 100.0).round() as usize;
        let mut people = People {
            params,
            grid,
            people: Vec::with_capacity(n),
            positions: Vec::with_capacity(n),
            rng,
            footprint,
        };
        if people.grid.cells.is_empty() {
            return Ok(people);
        }
        let r = params.radius;
        for _ in 0..n {
            // Rejection sampling: clear of the robot always, of other people if possible.
            let mut spot = None;
            for attempt in 0..100 {
                let c = people.grid.cells[people.rng.random_range(0..people.grid.cells.len())];
                let p = people.grid.centre(c);
                if footprint_distance(p, &start, footprint) < r + START_CLEARANCE {
                    continue;
                }
                let crowded = people
                    .people
                    .iter()
                    .any(|q| (q.pos[0] - p[0]).hypot(q.pos[1] - p[1]) < 2.0 * r);
                spot = Some(p);
                if !crowded || attempt >= 50 {
                    break;
                }
            }
            let Some(pos) = spot else { continue };
            // A cylinder's axis is its local +Y: stand it up along Z. Members of the people
            // group, filtering on it alone: the robot (which filters on the static groups)
            // never touches a person, and sensor rays (whose filter includes the group) see
            // them.
            let shape = Cylinder::new((0.5 * params.height) as f32, r as f32);
            let collider = ColliderBuilder::new(SharedShape::new(PersonShape(shape)))
                .rotation(Vector::new(std::f32::consts::FRAC_PI_2, 0.0, 0.0))
                .translation(person_translation(pos, params.height))
                .collision_groups(InteractionGroups::new(
                    PEOPLE_GROUP,
                    NOBODY_GROUP,
                    InteractionTestMode::And,
                ))
                .user_data(PERSON_TAG | ((people.people.len() as u128) << 8));
            let collider = scene.physics.insert_collider(collider, None);
            people.people.push(Person {
                pos,
                goal: pos,
                waited: 0.0,
                collider,
                placed: true,
            });
            people.positions.push(pos);
        }
        for i in 0..people.people.len() {
            people.new_goal(i, None);
        }
        Ok(people)
    }

    /// A random goal reachable in a straight line, else a neighbouring cell's centre. A
    /// person yielding to the robot at `yield_to` only takes a walk that never comes nearer
    /// its footprint than [`ROBOT_MARGIN`] (or than they already are).
    fn new_goal(&mut self, i: usize, yield_to: Option<&Pose2>) {
        let pos = self.people[i].pos;
        let g = &self.grid;
        let footprint = self.footprint;
        let keep = self.params.radius + ROBOT_MARGIN;
        let clear_of_robot = |goal: [f64; 2]| {
            let Some(robot) = yield_to else {
                return true;
            };
            let limit = keep.min(footprint_distance(pos, robot, footprint));
            let n = ((goal[0] - pos[0]).hypot(goal[1] - pos[1]) / CELL)
                .ceil()
                .max(1.0) as usize;
            (1..=n).all(|k| {
                let t = k as f64 / n as f64;
                let p = [
                    pos[0] + t * (goal[0] - pos[0]),
                    pos[1] + t * (goal[1] - pos[1]),
                ];
                footprint_distance(p, robot, footprint) >= limit
            })
        };
        for _ in 0..GOAL_TRIES {
            let c = g.cells[self.rng.random_range(0..g.cells.len())];
            let goal = g.centre(c);
            if (goal[0] - pos[0]).hypot(goal[1] - pos[1]) >= MIN_WALK
                && g.clear(pos, goal)
                && clear_of_robot(goal)
            {
                self.people[i].goal = goal;
                return;
            }
        }
        if let Some(c) = g.cell_of(pos) {
            let (nx, ny) = (g.nx, g.ny);
            let (ci, cj) = (c % nx, c / nx);
            let mut options = [usize::MAX; 4];
            let mut k = 0;
            for (di, dj) in [(-1i64, 0i64), (1, 0), (0, -1), (0, 1)] {
                let (i2, j2) = (ci as i64 + di, cj as i64 + dj);
                if i2 >= 0 && j2 >= 0 && (i2 as usize) < nx && (j2 as usize) < ny {
                    let d = j2 as usize * nx + i2 as usize;
                    if g.walkable[d] && clear_of_robot(g.centre(d)) {
                        options[k] = d;
                        k += 1;
                    }
                }
            }
            if k > 0 {
                self.people[i].goal = g.centre(options[self.rng.random_range(0..k)]);
            }
        }
    }

    /// Moves every person by one step of `dt` s with the robot's base at `robot`. Their
    /// colliders stay where they were until [`People::place`].
    pub fn step(&mut self, robot: &Pose2, dt: f64) {
        let keep = self.params.radius + ROBOT_MARGIN;
        for i in 0..self.people.len() {
            let Person { pos, goal, .. } = self.people[i];
            let (dx, dy) = (goal[0] - pos[0], goal[1] - pos[1]);
            let dist = dx.hypot(dy);
            let stride = self.params.speed * dt;
            if dist <= 1e-9 {
                self.new_goal(i, None);
                continue;
            }
            let f = stride.min(dist) / dist;
            let next = [pos[0] + f * dx, pos[1] + f * dy];
            let d_next = footprint_distance(next, robot, self.footprint);
            if d_next < keep && d_next < footprint_distance(pos, robot, self.footprint) {
                let p = &mut self.people[i];
                p.waited += dt;
                if p.waited >= PATIENCE_S {
                    p.waited = 0.0;
                    self.new_goal(i, Some(robot));
                }
                continue;
            }
            let p = &mut self.people[i];
            p.pos = next;
            p.waited = 0.0;
            p.placed = false;
            self.positions[i] = next;
            if stride >= dist {
                self.new_goal(i, None);
            }
        }
    }

    /// Moves the colliders of the people who walked since the last placement to where they
    /// are; the coming physics step brings them into the scene that rays query.
    pub fn place(&mut self, physics: &mut PhysicsWorld) {
        let height = self.params.height;
        for p in self.people.iter_mut().filter(|p| !p.placed) {
            if let Some(c) = physics.colliders.get_mut(p.collider) {
                c.set_translation(person_translation(p.pos, height));
            }
            p.placed = true;
        }
    }

    /// Every person's position (the centre of their disc on the floor), m.
    pub fn positions(&self) -> &[[f64; 2]] {
        &self.positions
    }

    pub fn params(&self) -> &PeopleParams {
        &self.params
    }

    /// The free floor connected to the robot's start, m² (what the density is per).
    pub fn floor_area(&self) -> f64 {
        self.grid.floor_area
    }

    /// Whether a person may stand at `p` (for tests and diagnostics).
    pub fn walkable(&self, p: [f64; 2]) -> bool {
        self.grid.walkable_at(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn validation_names_the_field() {
        let bad = [
            (
                PeopleParams {
                    density: -1.0,
                    ..Default::default()
                },
                "people.density",
            ),
            (
                PeopleParams {
                    density: f64::NAN,
                    ..Default::default()
                },
                "people.density",
            ),
            (
                PeopleParams {
                    density: 200.0,
                    ..Default::default()
                },
                "people.density",
            ),
            (
                PeopleParams {
                    speed: 0.0,
                    ..Default::default()
                },
                "people.speed",
            ),
            (
                PeopleParams {
                    radius: -0.1,
                    ..Default::default()
                },
                "people.radius",
            ),
            (
                PeopleParams {
                    height: f64::INFINITY,
                    ..Default::default()
                },
                "people.height",
            ),
        ];
        for (p, field) in bad {
            let e = p.validate().unwrap_err().to_string();
            assert!(e.contains(field), "{p:?}: {e}");
        }
        // The limit of a third of the floor at r = 0.25 m is 169.8 people per 100 m².
        assert!(PeopleParams {
            density: 169.0,
            ..Default::default()
        }
        .validate()
        .is_ok());
        assert!(PeopleParams {
            density: 171.0,
            ..Default::default()
        }
        .validate()
        .is_err());
        assert!(PeopleParams::default().validate().is_ok());
    }

    #[test]
    fn footprint_distance_follows_the_heading() {
        let fp = ([-0.2, -0.1], [0.3, 0.1]);
        let robot = Pose2::new(1.0, 1.0, std::f64::consts::FRAC_PI_2);
        // 0.5 m ahead of the base (+y in the world) is 0.2 m beyond the front.
        assert!((footprint_distance([1.0, 1.5], &robot, fp) - 0.2).abs() < 1e-12);
        assert_eq!(footprint_distance([1.0, 1.0], &robot, fp), 0.0);
        // 0.5 m to the robot's right (+x in the world) is 0.4 m beyond its side.
        assert!((footprint_distance([1.5, 1.0], &robot, fp) - 0.4).abs() < 1e-12);
    }

    #[test]
    fn walkable_cells_keep_a_person_out_of_walls() {
        let world = crate::fixtures::box_room(6.0, 4.0, "concrete");
        let grid = WalkGrid::new(&world, 0.25, [0.0, 0.0]);
        // Inner faces at x = ±2.9, y = ±1.9: a person's centre stays 0.25 m inside them.
        for &c in &grid.cells {
            let p = grid.centre(c);
            for k in [-0.5, 0.5] {
                let q = [p[0] + k * CELL, p[1] + k * CELL];
                assert!(
                    q[0].abs() <= 2.9 - 0.25 && q[1].abs() <= 1.9 - 0.25,
                    "{q:?}"
                );
            }
        }
        assert!(grid.walkable_at([0.0, 0.0]) && !grid.walkable_at([2.8, 0.0]));
        // Free floor: the 5.8 m x 3.8 m inside, to a cell.
        assert!(
            (grid.floor_area - 5.8 * 3.8).abs() < 2.0,
            "{}",
            grid.floor_area
        );
        assert!(!grid.clear([-2.0, 0.0], [2.9, 0.0]) && grid.clear([-2.0, 0.0], [2.0, 1.0]));
    }
}
