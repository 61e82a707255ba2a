//! clap's own consistency checks of the command line (the `--help` texts are pinned in `tests/cli.rs`).

use crate::app::Cli;
use clap::CommandFactory;

#[test]
fn cli_is_well_formed() {
    Cli::command().debug_assert();
}
