//! Atrium's own localizer kinds, registered through the same
//! [`LocalizerRegistry::register`] call a user's crate uses. This module is the only place
//! the built-in kinds are listed.

pub mod appearance;
pub mod appearance_filters;
pub mod camera;
pub mod cgr;
pub mod chooser;
pub mod landmark;
pub mod process;
pub mod wifi;

use crate::error::ScenarioError;
use crate::registry::{BuildContext, LocalizerRegistry};
use crate::scenario::InitialBelief;
use atrium_localization::dead_reckoning::DeadReckoning;
use atrium_localization::ekf_slam::{EkfSlam, EkfSlamParams};
use atrium_localization::mcl::{InitialBelief as MclBelief, Mcl, MclParams};
use atrium_localization::Localizer;

type Built = Result<Box<dyn Localizer>, ScenarioError>;
type Factory = fn(&mut BuildContext) -> Built;

impl LocalizerRegistry {
    /// A registry holding every built-in kind: `dead_reckoning`, `mcl`, `ekf_slam`,
    /// `cgr_laser`, `cgr_depth`, `wifi`, `landmark_filter`, `appearance`, `ceiling_mcl`,
    /// `omni`, `chooser`, `fused` and `process` (a localizer in another process, any
    /// language).
    pub fn with_builtins() -> Self {
        let mut r = LocalizerRegistry::empty();
        let kinds: [(&str, Factory); 13] = [
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
    Ok(Box::new(DeadReckoning::new(
        &ctx.spec.name,
        ctx.scenario.start,
    )))
}

fn mcl(ctx: &mut BuildContext) -> Built {
    let params: MclParams = ctx.params()?;
    params.validate().map_err(|msg| ctx.error("", msg))?;
    let map = ctx
        .maps
        .mcl_map(ctx.scenario, &params)
        .map_err(|e| ctx.error("", e.to_string()))?;
    let init = match &ctx.scenario.initial_belief {
        InitialBelief::Tracking { sigma } => MclBelief::Tracking {
            pose: ctx.scenario.start,
            sigma: *sigma,
        },
        InitialBelief::Global { polygons } => MclBelief::Global {
            regions: polygons.clone(),
        },
    };
    let mcl = Mcl::with_map(&ctx.spec.name, params, &map, init, ctx.seed())
        .map_err(|e| ctx.error("", e.to_string()))?;
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
    let slam = EkfSlam::new(&ctx.spec.name, params, ctx.scenario.start)
        .map_err(|msg| ctx.error("", msg))?;
    Ok(Box::new(slam))
}
