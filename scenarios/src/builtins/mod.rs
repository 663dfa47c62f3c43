//! Atrium's own localizer kinds, registered through the same
//! [`LocalizerRegistry::register`] call a user's crate uses. This module is the only place
//! the built-in kinds are listed.

pub mod appearance;
pub mod appearance_filters;
pub mod camera;
mod camera_maps;
pub mod cgr;
pub mod chooser;
pub mod landmark;
mod param_errors;
pub mod process;
pub mod start_pose;
pub mod wifi;

use crate::error::ScenarioError;
use crate::registry::{BuildContext, LocalizerRegistry};
use crate::scenario::InitialBelief;
use atrium_localization::dead_reckoning::DeadReckoning;
use atrium_localization::ekf_slam::{EkfSlam, EkfSlamParams};
use atrium_localization::mcl::{InitialBelief as MclBelief, Mcl, MclParams};
use atrium_localization::Localizer;
use param_errors::{localization_error, param_error};

type Built = Result<Box<dyn Localizer>, ScenarioError>;
type Factory = fn(&mut BuildContext) -> Built;

impl LocalizerRegistry {
    /// A registry holding every built-in kind: `dead_reckoning`, `mcl`, `ekf_slam`,
    /// `cgr_laser`, `cgr_depth`, `wifi`, `landmark_filter`, `appearance`, `ceiling_mcl`,
    /// `omni`, `chooser`, `fused`, `process` (a localizer in another process, any
    /// language) and `start_pose` (a stand-in that never moves from the start).
    pub fn with_builtins() -> Self {
        let mut r = LocalizerRegistry::empty();
        let kinds: [(&str, Factory); 14] = [
            ("dead_reckoning", dead_reckoning),
            ("mcl", mcl),
            ("ekf_slam", ekf_slam),
            ("cgr_laser", |c| {
                cgr::build(c.spec, c.scenario, c.maps, c.seed())
            }),
            ("cgr_depth", |c| {
                cgr::build(c.spec, c.scenario, c.maps, c.seed())
            }),
            ("wifi", |c| {
                let seed = c.seed();
                let grid = c.maps.occupancy_grid(c.scenario);
                wifi::build_wifi_localizer(c.spec, c.scenario, grid, seed)
            }),
            ("landmark_filter", landmark::build),
            ("appearance", |c| {
                appearance::build(c.spec, c.scenario, c.seed())
            }),
            ("ceiling_mcl", |c| {
                camera::build_ceiling_mcl(c.spec, c.scenario, c.seed())
            }),
            ("omni", |c| camera::build_omni(c.spec, c.scenario, c.seed())),
            ("chooser", chooser::build),
            ("fused", chooser::build),
            ("process", process::build),
            ("start_pose", start_pose),
        ];
        for (kind, factory) in kinds {
            r.register(kind, factory)
                .expect("the built-in kinds are distinct and well named");
        }
        r
    }
}

fn dead_reckoning(ctx: &mut BuildContext) -> Built {
    if let Some(k) = ctx.spec.params.keys().next() {
        return Err(ctx.error(k, "dead_reckoning takes no parameters"));
    }
    let start = dead_reckoning_start(ctx.scenario, ctx.seed());
    Ok(Box::new(DeadReckoning::new(&ctx.spec.name, start)))
}

/// The start stand-in starts where dead reckoning does, and stays there.
fn start_pose(ctx: &mut BuildContext) -> Built {
    if let Some(k) = ctx.spec.params.keys().next() {
        return Err(ctx.error(k, "start_pose takes no parameters"));
    }
    let start = dead_reckoning_start(ctx.scenario, ctx.seed());
    Ok(Box::new(start_pose::StartPose::new(&ctx.spec.name, start)))
}

/// Where dead reckoning starts: what the other localizers are told, no more. Tracking: the
/// initial belief's mean (the start). Global: one pose drawn uniformly from the belief's
/// free space with a uniform heading, so a baseline never gets a global start for free.
fn dead_reckoning_start(scenario: &crate::Scenario, seed: u64) -> atrium_robots::Pose2 {
    use rand::{Rng, SeedableRng};
    let polygons = match &scenario.initial_belief {
        InitialBelief::Tracking { .. } => return scenario.start,
        InitialBelief::Global { polygons } => polygons,
    };
    let (lo, hi) = if polygons.is_empty() {
        scenario.world.bounds()
    } else {
        let points = polygons.iter().flatten();
        let lo = points
            .clone()
            .fold([f64::MAX; 2], |m, p| [m[0].min(p[0]), m[1].min(p[1])]);
        let hi = points.fold([f64::MIN; 2], |m, p| [m[0].max(p[0]), m[1].max(p[1])]);
        (lo, hi)
    };
    let inside = |p: [f64; 2]| {
        polygons.is_empty()
            || polygons
                .iter()
                .any(|poly| atrium_worlds::geometry::point_in_polygon(p, poly))
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    // Rejection sampling: the belief's regions fill a good part of their bounding box, so
    // this ends after a few draws; the start is the fallback for a belief with no free space.
    for _ in 0..100_000 {
        let p = [
            rng.random_range(lo[0]..=hi[0]),
            rng.random_range(lo[1]..=hi[1]),
        ];
        if inside(p) && scenario.world.is_free(p, 0.3) {
            let theta = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
            return atrium_robots::Pose2::new(p[0], p[1], theta);
        }
    }
    scenario.start
}

fn mcl(ctx: &mut BuildContext) -> Built {
    let params: MclParams = ctx.params()?;
    let (file, prefix) = (&ctx.scenario.file, ctx.field());
    let bad = |msg: String| param_error(file, &prefix, &params, &msg);
    params.validate().map_err(bad)?;
    // The likelihood field's size, from the map's before either is built (the scenario's
    // loading checked that the map itself fits).
    if let Ok(size) = ctx.scenario.world.grid_size(ctx.scenario.map.resolution) {
        let extent = [
            size.width as f64 * size.resolution,
            size.height as f64 * size.resolution,
        ];
        params.check_field_size(extent).map_err(bad)?;
    }
    let map = ctx
        .maps
        .mcl_map(ctx.scenario, &params)
        .map_err(|e| localization_error(file, &prefix, &params, e))?;
    let init = match &ctx.scenario.initial_belief {
        InitialBelief::Tracking { sigma } => MclBelief::Tracking {
            pose: ctx.scenario.start,
            sigma: *sigma,
        },
        InitialBelief::Global { polygons } => MclBelief::Global {
            regions: polygons.clone(),
        },
    };
    let mcl = Mcl::with_map(&ctx.spec.name, params.clone(), &map, init, ctx.seed())
        .map_err(|e| localization_error(file, &prefix, &params, e))?;
    Ok(Box::new(mcl))
}

fn ekf_slam(ctx: &mut BuildContext) -> Built {
    let mut params: EkfSlamParams = ctx.params()?;
    let Some(d) = ctx.scenario.landmark_detectors.first() else {
        return Err(ctx.error(
            "kind",
            "ekf_slam needs point features: add a [landmark_detector] table",
        ));
    };
    // The filter assumes the detector's noise unless the file says otherwise.
    params.sigma_range.get_or_insert(d.sigma_range);
    params.sigma_bearing.get_or_insert(d.sigma_bearing);
    let (file, prefix) = (&ctx.scenario.file, ctx.field());
    let slam = EkfSlam::new(&ctx.spec.name, params.clone(), ctx.scenario.start)
        .map_err(|msg| param_error(file, &prefix, &params, &msg))?;
    Ok(Box::new(slam))
}
