//! Back-off (constraint tightening): `[mpc] x_backoff` and each `[[mpc.constraint]]`'s `backoff` pull
//! the finite bounds in by a margin m ≥ 0, lower + m ≤ row ≤ upper − m, before the rows are lowered, so
//! every method solves the tightened QP and the true state keeps a bound that the plan of the estimate
//! keeps with m to spare.
//!
//! A margin is written in the bound's units, or as `"<z>sigma"`: z standard deviations of the Kalman
//! filter's steady-state estimation error along the row, m = z·√(a·P∞·aᵀ), with a the row's state
//! coefficients (the unit vector of the state for `x_backoff`) and P∞ the state block of the filter's
//! steady-state a priori covariance, the error of the one-step prediction that the first planned
//! state x_1 stands for. The same margin holds at every stage: the plan is solved again at each step
//! from a new estimate, so only the error of one step reaches the true state.
#![allow(non_snake_case)]

use crate::lower::constraints::RowKind;
use mpc_spec::{Backoff, Constraints, Diagnostic, Diagnostics, Spec};
use nalgebra::{DMatrix, DVector};

/// One tightened constraint, for the report.
#[derive(Clone, Debug, PartialEq)]
pub struct Margin {
    /// The state bound or group row (`upper` `None`: both sides).
    pub kind: RowKind,
    /// The margin, in the bound's units.
    pub margin: f64,
    /// For `"<z>sigma"`: z and the standard deviation σ = √(a·P∞·aᵀ) it multiplies.
    pub sigmas: Option<(f64, f64)>,
}

impl Margin {
    /// `x_max[1]: 0.094 (3σ, σ = 0.031)`.
    pub fn describe(&self) -> String {
        match self.sigmas {
            Some((z, sigma)) => format!(
                "{}: {:.3e} ({z}σ, σ = {sigma:.3e})",
                self.kind.name(),
                self.margin
            ),
            None => format!("{}: {:.3e}", self.kind.name(), self.margin),
        }
    }
}

/// The constraints of `spec` with their back-offs applied, and the margins (nonzero ones, in the order
/// of the rows). `P` is the state block of the filter's P∞, `None` without a filter (the spec's check
/// refuses `"<z>sigma"` then). Fails where a margin leaves a lower bound above its upper one.
pub fn tighten(
    spec: &Spec,
    P: Option<&DMatrix<f64>>,
) -> Result<(Constraints, Vec<Margin>), Diagnostics> {
    let mut c = spec.mpc.constraints.clone();
    let mut margins = Vec::new();
    let mut diags = Diagnostics::default();
    let nx = spec.model.kind.nx();
    let std_along = |a: &DVector<f64>| P.map(|P| (a.transpose() * P * a)[(0, 0)].max(0.0).sqrt());
    if let Some(backoff) = c.x_backoff.clone() {
        let key = "mpc.x_backoff";
        for i in 0..nx {
            let lo = c.x_min.get(i).copied().unwrap_or(f64::NEG_INFINITY);
            let hi = c.x_max.get(i).copied().unwrap_or(f64::INFINITY);
            if !lo.is_finite() && !hi.is_finite() {
                continue;
            }
            let unit = DVector::from_fn(nx, |j, _| if i == j { 1.0 } else { 0.0 });
            let Some((margin, sigmas)) = margin_of(&backoff, i, std_along(&unit)) else {
                continue;
            };
            let kind = RowKind::State {
                index: i,
                upper: None,
            };
            match pulled_in(lo, hi, margin) {
                Some((lo, hi)) => {
                    if let Some(b) = c.x_min.get_mut(i) {
                        *b = lo;
                    }
                    if let Some(b) = c.x_max.get_mut(i) {
                        *b = hi;
                    }
                }
                None => diags.push(inverted(spec, key, i, &kind, lo, hi, margin)),
            }
            margins.push(Margin {
                kind,
                margin,
                sigmas,
            });
        }
    }
    for (g, group) in c.rows.iter_mut().enumerate() {
        let Some(backoff) = group.backoff.clone() else {
            continue;
        };
        let key = format!("mpc.constraint[{g}].backoff");
        for r in 0..group.lower.len() {
            let a = DVector::from_fn(nx, |j, _| group.ax.get(r, j));
            let Some((margin, sigmas)) = margin_of(&backoff, r, std_along(&a)) else {
                continue;
            };
            let kind = RowKind::Group {
                group: g,
                row: r,
                upper: None,
            };
            let (lo, hi) = (group.lower[r], group.upper[r]);
            match pulled_in(lo, hi, margin) {
                Some((lo, hi)) => {
                    group.lower[r] = lo;
                    group.upper[r] = hi;
                }
                None => diags.push(inverted(spec, &key, r, &kind, lo, hi, margin)),
            }
            margins.push(Margin {
                kind,
                margin,
                sigmas,
            });
        }
    }
    if diags.is_empty() {
        Ok((c, margins))
    } else {
        Err(diags.sorted())
    }
}

/// Entry `i`'s margin and, for `"<z>sigma"`, (z, σ); `None` for a zero margin (nothing to report).
fn margin_of(b: &Backoff, i: usize, sigma: Option<f64>) -> Option<(f64, Option<(f64, f64)>)> {
    let (margin, sigmas) = match b {
        Backoff::Margin(m) => (m[i], None),
        Backoff::Sigmas(z) => {
            let sigma = sigma.unwrap_or(0.0);
            (z * sigma, Some((*z, sigma)))
        }
    };
    (margin > 0.0).then_some((margin, sigmas))
}

/// [lo + m, hi − m] (an infinite side stays infinite), `None` when it is empty.
fn pulled_in(lo: f64, hi: f64, m: f64) -> Option<(f64, f64)> {
    let (lo, hi) = (lo + m, hi - m);
    (lo <= hi).then_some((lo, hi))
}

fn inverted(
    spec: &Spec,
    key: &str,
    i: usize,
    kind: &RowKind,
    lo: f64,
    hi: f64,
    m: f64,
) -> Diagnostic {
    let span = spec
        .spans
        .get(&format!("{key}[{i}]"))
        .or(spec.spans.get(key));
    Diagnostic::new(
        format!(
            "the back-off of {m:.4e} leaves nothing of `{}`: its bounds {lo} and {hi} are closer than two margins",
            kind.name()
        ),
        span,
    )
    .label("pulls the lower bound above the upper one")
    .note("hint: a back-off pulls each finite bound in by the margin; shrink it (or the sensors' noise, for \"<z>sigma\"), or widen the bounds")
}
