//! `atrium score` (placeholder while it lands).
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct ScoreArgs {
    pub recording: PathBuf,
    pub estimates: PathBuf,
}

pub fn score_command(_args: ScoreArgs) -> anyhow::Result<bool> {
    anyhow::bail!("atrium score is not built yet")
}
