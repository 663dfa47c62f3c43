//! `atrium`: the command-line tool with Atrium's built-in localizer kinds.

fn main() -> std::process::ExitCode {
    atrium_cli::main_with(atrium_scenarios::LocalizerRegistry::with_builtins())
}
