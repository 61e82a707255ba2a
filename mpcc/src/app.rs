//! The command line.

use clap::{Parser, Subcommand};
use std::path::PathBuf;

/// The `mpc!` compiler on the command line: what it proves about a controller spec, and the code it emits.
#[derive(Parser, Debug)]
#[command(name = "mpcc", version, about, long_about = None)]
#[command(
    help_template = "{before-help}{name} {version}\n{about}\n\n{usage-heading} {usage}\n\n{all-args}{after-help}"
)]
pub(crate) struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub(crate) enum Command {
    /// Check a spec and print what the compiler proves about it: conditioning, rates, iteration bound,
    /// closed-loop stability, resources.
    Check {
        /// The TOML controller spec: a regular file of at most 1 MiB, or `-` for standard input.
        #[arg(value_name = "SPEC")]
        spec: PathBuf,
        /// Print the certificate as JSON, under stable names.
        #[arg(long)]
        json: bool,
        /// Draw the dual active-set method's cold iteration count over two parameters of `[mpc.region]`
        /// into FILE (SVG), every other parameter at the region's centre.
        #[arg(long, value_name = "FILE")]
        plot: Option<PathBuf>,
        /// The two parameters of `--plot`, by name (`x0[0]`, `r[1]`, `u_prev[0]`, `d[0]`) or index into θ;
        /// default the first two states.
        #[arg(long, value_name = "A,B", requires = "plot")]
        plot_axes: Option<String>,
    },
    /// Print the module `mpc!` generates from a spec, formatted as a person would read it.
    Emit {
        /// The TOML controller spec: a regular file of at most 1 MiB, or `-` for standard input; the module
        /// is named after its file stem (`controller` for `-`).
        #[arg(value_name = "SPEC")]
        spec: PathBuf,
        /// Write the module to FILE instead of printing it: a regular file only if its content changed,
        /// never the SPEC itself.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
        /// Write a crate that builds the controller as a C static library, and its header NAME.h, into
        /// DIR instead of printing the module (docs/c-api.md).
        #[arg(long = "c", value_name = "DIR", conflicts_with = "output")]
        c: Option<PathBuf>,
        /// The rustc target triple of the C static library; by default the spec's `[codegen] target`
        /// (cortex-m4f: thumbv7em-none-eabihf, cortex-a9: armv7a-none-eabihf, host: the host).
        #[arg(long, value_name = "TRIPLE", requires = "c")]
        target: Option<String>,
    },
    /// Write the condensed QP of a spec and a closed loop's states as JSON, for other solvers (format
    /// `mpcc-qp/1`, peers/README.md)
    DumpQp {
        /// The TOML controller spec: a regular file of at most 1 MiB, or `-` for standard input.
        #[arg(value_name = "SPEC")]
        spec: PathBuf,
        /// The first state of the closed loop (nx numbers, commas or spaces; default zero).
        #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
        x0: Option<String>,
        /// The constant reference of every step of the window (nz numbers; default zero).
        #[arg(long, value_name = "LIST", allow_hyphen_values = true)]
        reference: Option<String>,
        /// Steps of the closed loop on the nominal model.
        #[arg(long, default_value_t = 100)]
        steps: usize,
        /// Replay these states instead of a closed loop: one state per line, `#` comments.
        #[arg(long, value_name = "FILE", conflicts_with_all = ["x0", "steps"])]
        states: Option<PathBuf>,
        /// One step: the worst cold case of the spec's sampled certificate (its x0 and constant
        /// reference, `mpcc check`'s "the worst cold case"), for a board to replay against the bound.
        #[arg(long, conflicts_with_all = ["x0", "reference", "steps", "states"])]
        witness: bool,
        /// Write the JSON to FILE instead of printing it.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
}
