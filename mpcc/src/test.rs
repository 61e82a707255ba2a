//! clap's own consistency checks of the command line (the `--help` texts are pinned in `tests/cli.rs`).

use crate::app::Cli;
use clap::CommandFactory;

#[test]
fn cli_is_well_formed() {
    Cli::command().debug_assert();
}

/// The SPEC help of both subcommands states the limit that `input` enforces.
#[test]
fn spec_help_states_the_size_limit() {
    let limit = format!("at most {} MiB", codegen::input::SPEC_SIZE_LIMIT_MIB);
    let command = Cli::command();
    for sub in ["check", "emit"] {
        let spec = command
            .find_subcommand(sub)
            .and_then(|c| c.get_arguments().find(|a| a.get_id() == "spec"))
            .unwrap();
        let help = spec.get_help().unwrap().to_string();
        assert!(help.contains(&limit), "{sub}: {help}");
    }
}
