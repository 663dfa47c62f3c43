//! A user's own localizer kind for Atrium, registered without editing Atrium: `wall_ekf`,
//! an EKF over (x, y, θ) that predicts with wheel odometry and corrects with laser ranges
//! ray-cast against the world's vector map (see [`ekf`]).
//!
//! ```
//! let mut registry = atrium_scenarios::LocalizerRegistry::with_builtins();
//! custom_localizer::register(&mut registry).unwrap();
//! assert!(registry.contains("wall_ekf"));
//! ```
//!
//! `tests/` runs it in bundled scenarios and a sweep; see the README.

pub mod ekf;
pub mod walls;

pub use ekf::{Params, WallEkf};
pub use walls::Walls;

use atrium_localization::Localizer;
use atrium_scenarios::scenario::InitialBelief;
use atrium_scenarios::{BuildContext, LocalizerRegistry, RegistryError, ScenarioError};

/// The kind a scenario's `[[localizers]]` entry names to get a [`WallEkf`].
pub const KIND: &str = "wall_ekf";

/// Adds the `wall_ekf` kind to `registry`.
pub fn register(registry: &mut LocalizerRegistry) -> Result<(), RegistryError> {
    registry.register(KIND, build)?;
    Ok(())
}

/// Builds one `wall_ekf` from its `[[localizers]]` table.
pub fn build(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
    let params: Params = ctx.params()?;
    params
        .validate()
        .map_err(|(key, msg)| ctx.error(key, msg))?;
    let sigma =
        match &ctx.scenario.initial_belief {
            InitialBelief::Tracking { sigma } => *sigma,
            InitialBelief::Global { .. } => return Err(ctx.error(
                "",
                "wall_ekf tracks from a known start: it needs [initial_belief] mode = \"tracking\"",
            )),
        };
    if ctx.scenario.lasers.is_empty() {
        return Err(ctx.error("", "wall_ekf needs a laser and the robot has none"));
    }
    let walls = Walls::new(ctx.maps.vector_map(ctx.scenario));
    let start = ctx.scenario.start;
    Ok(Box::new(WallEkf::new(
        &ctx.spec.name,
        start,
        sigma,
        walls,
        params,
    )))
}
