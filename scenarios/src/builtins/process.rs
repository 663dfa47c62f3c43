//! `kind = "process"` (placeholder while the protocol lands).
use crate::error::ScenarioError;
use crate::registry::BuildContext;
use atrium_localization::Localizer;

pub fn build(ctx: &mut BuildContext) -> Result<Box<dyn Localizer>, ScenarioError> {
    Err(ctx.error("kind", "process localizers are not built yet"))
}
