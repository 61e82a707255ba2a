#![doc = include_str!("../README.md")]

mod app;
mod c_target;
mod check;
mod dump;
mod emit;
mod error;
mod input;
mod plot;
#[cfg(test)]
mod test;

use crate::app::{Cli, Command};
use crate::error::{Error, Result};
use crate::plot::GRID;
use clap::Parser;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

fn main() -> ExitCode {
    match try_main() {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprint!("{}", error::report(&error));
            ExitCode::FAILURE
        }
    }
}

fn try_main() -> Result<()> {
    match Cli::parse().command {
        Command::Check {
            spec,
            json,
            plot,
            plot_axes,
        } => {
            let loaded = Loaded::read(&spec)?;
            let generated = loaded.generate("controller")?;
            loaded.print_warnings(&generated.warnings);
            if let Some(file) = &plot {
                let d = plot::draw(&loaded.source, &generated, plot_axes.as_deref(), file)
                    .map_err(|why| Error::Plot(file.clone(), why))?;
                eprintln!(
                    "mpcc: drew {} ({GRID} × {GRID} cold solves over {} × {}): {}-{} changes of the working set, the cold cap {}{}{}",
                    file.display(),
                    d.axes[0],
                    d.axes[1],
                    d.range.0,
                    d.range.1,
                    d.cap,
                    if d.infeasible > 0 {
                        format!(", {} infeasible cells (grey)", d.infeasible)
                    } else {
                        String::new()
                    },
                    if d.above_cap > 0 {
                        format!(", {} cells ABOVE the cap", d.above_cap)
                    } else {
                        String::new()
                    },
                );
            }
            let text = if json {
                check::json(&loaded.shown, &generated)
            } else {
                check::text(&loaded.shown, &generated)
            };
            print(&text)
        }
        Command::Emit {
            spec,
            output,
            c,
            target,
        } => {
            let loaded = Loaded::read(&spec)?;
            if let Some(output) = &output {
                if !input::is_stdin(&spec) && emit::same_file(&spec, output) {
                    return Err(Error::SameFile {
                        spec,
                        output: output.clone(),
                    });
                }
            }
            let generated = loaded.generate(&emit::module_name(&spec))?;
            loaded.print_warnings(&generated.warnings);
            if let Some(dir) = c {
                let triple = match target {
                    Some(t) => (t != "host").then_some(t),
                    None => mpc_spec::load(&loaded.source)
                        .ok()
                        .and_then(|s| c_target::default_triple(s.codegen.target))
                        .map(String::from),
                };
                let header =
                    codegen::c_api::write_crate(&dir, &generated, &loaded.shown, triple.as_deref())
                        .map_err(|why| Error::CTarget(dir.clone(), why))?;
                return print(&format!("{}\n", header.display()));
            }
            let text = generated.pretty();
            match output {
                None => print(&text),
                Some(path) => emit::write(&path, &text).map_err(|e| Error::Write(path, e)),
            }
        }
        Command::DumpQp {
            spec,
            x0,
            reference,
            steps,
            states,
            witness,
            output,
        } => {
            let loaded = Loaded::read(&spec)?;
            if witness {
                let generated = loaded.generate("controller")?;
                loaded.print_warnings(&generated.warnings);
                let (x0, reference) =
                    dump::witness(&generated.problem, generated.certificate.sampled.as_ref())
                        .map_err(Error::Dump)?;
                let states = dump::States::Given(vec![x0]);
                let value = dump::dump(&loaded.shown, &generated.problem, &states, &reference)
                    .map_err(Error::Dump)?;
                return write_dump(&value, output);
            }
            let parsed =
                mpc_spec::load(&loaded.source).map_err(|diags| loaded.spec_error(&diags))?;
            let problem = codegen::lower(&parsed).map_err(|diags| loaded.spec_error(&diags))?;
            let list = |text: &Option<String>, n: usize| match text {
                Some(t) => dump::numbers(t).map_err(Error::Dump),
                None => Ok(vec![0.0; n]),
            };
            let states = match states {
                Some(path) => {
                    let text = std::fs::read_to_string(&path).map_err(|e| {
                        Error::Dump(format!("cannot read `{}`: {e}", path.display()))
                    })?;
                    dump::States::Given(dump::read_states(&text).map_err(Error::Dump)?)
                }
                None => dump::States::ClosedLoop {
                    x0: list(&x0, problem.nx)?,
                    steps,
                },
            };
            let reference = list(&reference, problem.qp.nz)?;
            let value =
                dump::dump(&loaded.shown, &problem, &states, &reference).map_err(Error::Dump)?;
            write_dump(&value, output)
        }
    }
}

/// Writes a dump to `output`, or prints it.
fn write_dump(value: &serde_json::Value, output: Option<PathBuf>) -> Result<()> {
    let text = format!("{value}\n");
    match output {
        None => print(&text),
        Some(path) => std::fs::write(&path, text).map_err(|e| Error::Write(path, e)),
    }
}

/// Writes `text` to stdout; a closed pipe (`mpcc emit SPEC | head`) ends the output quietly.
fn print(text: &str) -> Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(Error::Stdout(e)),
        _ => Ok(()),
    }
}

/// A spec read from a file or from standard input.
struct Loaded {
    /// The path as given on the command line, or `<stdin>`: how diagnostics and the emitted docs name it.
    shown: String,
    source: String,
}

impl Loaded {
    /// Reads the spec at `path`, or standard input for `-` (see `input` for the limits).
    fn read(path: &Path) -> Result<Self> {
        if input::is_stdin(path) {
            return Ok(Loaded {
                shown: "<stdin>".into(),
                source: input::read_stdin().map_err(Error::ReadStdin)?,
            });
        }
        let source = input::read_file(path).map_err(|e| Error::Read(path.to_path_buf(), e))?;
        Ok(Loaded {
            shown: path.display().to_string(),
            source,
        })
    }

    /// Parses, checks, lowers, certifies and emits, as `mpc!` does; origin is the path as given, so the
    /// output does not depend on the machine.
    fn generate(&self, name: &str) -> Result<codegen::Generated> {
        let opt = codegen::Opt::new(name, "pub", codegen::Origin::Named(self.shown.clone()));
        codegen::generate_from_source(&self.source, &opt).map_err(|diags| Error::Spec {
            path: PathBuf::from(&self.shown),
            count: diags.0.len(),
            rendered: codegen::render::render(&diags, &self.source, &self.shown),
        })
    }

    /// The error of a spec with mistakes, rendered against its source.
    fn spec_error(&self, diags: &codegen::Diagnostics) -> Error {
        Error::Spec {
            path: PathBuf::from(&self.shown),
            count: diags.0.len(),
            rendered: codegen::render::render(diags, &self.source, &self.shown),
        }
    }

    fn print_warnings(&self, warnings: &codegen::Diagnostics) {
        for w in warnings.iter() {
            eprintln!(
                "{}\n",
                codegen::render::render_warning(w, &self.source, &self.shown)
            );
        }
    }
}
