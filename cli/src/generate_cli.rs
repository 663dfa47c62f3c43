//! `atrium generate world GENERATOR.toml [--set KEY=VALUE ...] -o WORLD.toml`: a world made
//! from a generator file, written as the explicit world file it stands for.

use std::path::{Path, PathBuf};

use anyhow::Context;
use atrium_scenarios::output;
use atrium_worlds::{GeneratorFile, GeneratorRegistry};

#[derive(clap::Args)]
pub struct GenerateArgs {
    #[command(subcommand)]
    what: GenerateWhat,
}

#[derive(clap::Subcommand)]
enum GenerateWhat {
    /// Make a world from a generator file (`generator = "office_atrium"` plus parameters)
    /// and write it as an explicit world file, validated like a hand-written one.
    World {
        /// The generator file.
        generator: PathBuf,
        /// Override a parameter: KEY=VALUE, VALUE a TOML value (`20`, `0.5`, `"name"`;
        /// other text is taken as a string). Repeat for several.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
        /// The world file to write (written under a temporary name, then renamed).
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
    },
}

/// Runs `atrium generate`; every error is bad input (exit 2).
pub fn generate_command(args: GenerateArgs) -> anyhow::Result<bool> {
    match args.what {
        GenerateWhat::World {
            generator,
            set,
            output,
        } => generate_world(&generator, &set, &output),
    }
}

fn generate_world(generator: &Path, set: &[String], out: &Path) -> anyhow::Result<bool> {
    // Before any work: the output must not be the generator file itself.
    output::refuse_overwriting_inputs(out, &[generator])
        .and_then(|()| output::check_writable_file(out, "-o"))
        .map_err(anyhow::Error::msg)?;
    let mut file = GeneratorFile::load(generator)?;
    for arg in set {
        file.set_arg(arg)?;
    }
    let (text, world) = file.generate_with_text(&GeneratorRegistry::with_builtins())?;
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("-o {}", out.display()))?;
    }
    output::write_atomic(out, text.as_bytes()).with_context(|| format!("-o {}", out.display()))?;
    let glass = world
        .walls
        .iter()
        .filter(|w| world.is_glass(&w.material))
        .count();
    eprintln!(
        "wrote {}: world {:?}, {} walls ({glass} glass), {} pillars, {} regions, {} clutter \
         boxes, {} access points",
        out.display(),
        world.name,
        world.walls.len(),
        world.pillars.len(),
        world.regions.len(),
        world.boxes.len(),
        world.access_points.len()
    );
    Ok(true)
}
