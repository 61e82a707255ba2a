#![doc = include_str!("../README.md")]
#![warn(missing_docs)]

mod check;
mod diag;
pub mod keys;
mod model;
mod parse;

pub use diag::{Diagnostic, Diagnostics};

/// The longest horizon a spec may ask for: the emitted code unrolls products that grow as N².
pub const MAX_HORIZON: usize = 250;

/// The most axes a `double_integrator` may have: every weight and covariance is a dense (2·axes)² matrix
/// in the spec already, and the compiler's budgets (`codegen::budget`) refuse far smaller controllers.
pub const MAX_AXES: usize = 1000;
/// The largest magnitude of a coefficient of `[[mpc.constraint]]` (`ax`, `au`): the interior-point
/// method's normal matrix sums products of two coefficients of a row times its weight λ/s, so a
/// coefficient's square, times the weights the method reaches (up to about 1/ε² ≈ 2e31) and summed over
/// the rows, must stay well inside f64 (1.8e308).
pub const MAX_ROW_COEFFICIENT: f64 = 1e100;

pub use model::*;

/// Parses and validates a spec, reporting every problem at once, sorted by position.
pub fn load(source: &str) -> Result<Spec, Diagnostics> {
    let mut diags = Diagnostics::default();
    let raw = parse::parse(source, &mut diags);
    match check::check(raw, &mut diags) {
        Some(spec) if diags.is_empty() => Ok(spec),
        _ if diags.is_empty() => Err(Diagnostic::new("invalid spec", None).into()),
        _ => Err(diags.sorted()),
    }
}
