//! Back-off (docs/spec.md, "Back-off"): the lowered rows of a spec with `x_backoff` and a group's
//! `backoff` are those of the same spec with its bounds moved in by hand, and `"<z>sigma"` is z times the
//! standard deviation along the row of the filter's steady-state covariance, computed here by the
//! Kalman filter's Riccati recursion iterated to convergence (not by the compiler's code).
#![allow(non_snake_case)]

use codegen::lower::uncertified;
use mpc_spec::load;
use nalgebra::{DMatrix, DVector};

/// A discrete plant with two states (position, velocity) and one input, the position measured, the
/// interior-point method; `bounds` are the lines of `[mpc]` after the input box, `group` the
/// `[[mpc.constraint]]` lines.
fn spec(bounds: &str, group: &str) -> String {
    format!(
        r#"[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005], [0.1]]
c = [[1, 0]]

[mpc]
horizon = 8
method = "ipm"
iterations = "auto"
q = [[1, 0], [0, 0.1]]
r = 0.1
u_min = [-1]
u_max = [1]
{bounds}

[[mpc.constraint]]
ax = [[1, 1]]
au = [[0.5]]
{group}

[mpc.region]
x_min = [-1, -1]
x_max = [1, 1]

[kalman]
q = [[0.0001, 0], [0, 0.01]]
r = [[0.04]]
"#
    )
}

fn rows(src: &str) -> codegen::constraints::Rows {
    let spec = load(src).unwrap_or_else(|d| panic!("{d:?}"));
    uncertified(&spec)
        .unwrap_or_else(|d| panic!("{d:?}"))
        .qp
        .rows
}

/// The filter's steady-state a priori covariance, P ← F(P − PCᵀ(CPCᵀ + R)⁻¹CP)Fᵀ + Q to convergence.
fn steady_state_covariance() -> DMatrix<f64> {
    let F = DMatrix::from_row_slice(2, 2, &[1.0, 0.1, 0.0, 1.0]);
    let C = DMatrix::from_row_slice(1, 2, &[1.0, 0.0]);
    let Q = DMatrix::from_row_slice(2, 2, &[1e-4, 0.0, 0.0, 1e-2]);
    let R = 0.04;
    let mut P = DMatrix::identity(2, 2);
    for _ in 0..100_000 {
        let S = (&C * &P * C.transpose())[(0, 0)] + R;
        let posterior = &P - &P * C.transpose() * &C * &P / S;
        P = &F * posterior * F.transpose() + &Q;
    }
    P
}

#[test]
fn a_margin_moves_the_bounds_as_if_written_moved() {
    let backed = rows(&spec(
        "x_min = [-2, -inf]\nx_max = [2, 1]\nx_backoff = [0.25, 0.1]",
        "lower = [-3]\nupper = [3]\nbackoff = 0.5",
    ));
    let by_hand = rows(&spec(
        "x_min = [-1.75, -inf]\nx_max = [1.75, 0.9]",
        "lower = [-2.5]\nupper = [2.5]",
    ));
    assert_eq!(backed.A, by_hand.A);
    assert_eq!(backed.Wx, by_hand.Wx);
    assert_eq!(backed.lower, by_hand.lower);
    assert_eq!(backed.upper, by_hand.upper);
    // An infinite bound stays infinite.
    assert!(backed.lower.iter().any(|b| *b == f64::NEG_INFINITY));
}

#[test]
fn sigmas_are_the_filters_steady_state_error_along_the_row() {
    let P = steady_state_covariance();
    let a = DVector::from_row_slice(&[1.0, 1.0]);
    let sigma_row = (a.transpose() * &P * &a)[(0, 0)].sqrt();
    let sigma_position = P[(0, 0)].sqrt();
    let src = spec(
        "x_max = [2, inf]\nx_backoff = \"2sigma\"",
        "upper = [3]\nbackoff = \"3sigma\"",
    );
    let spec = load(&src).unwrap();
    let p = uncertified(&spec).unwrap();
    let margins: Vec<(String, f64)> =
        p.qp.backoff
            .iter()
            .map(|m| (m.kind.name(), m.margin))
            .collect();
    assert_eq!(margins.len(), 2, "{margins:?}");
    assert_eq!(margins[0].0, "x_min/x_max[0]");
    assert!(
        (margins[0].1 - 2.0 * sigma_position).abs() < 1e-9 * sigma_position,
        "{margins:?} against 2σ = {}",
        2.0 * sigma_position
    );
    assert_eq!(margins[1].0, "constraint[0] row 0");
    assert!(
        (margins[1].1 - 3.0 * sigma_row).abs() < 1e-9 * sigma_row,
        "{margins:?} against 3σ = {}",
        3.0 * sigma_row
    );
    // And the rows hold the bounds moved by them.
    let moved = rows(&spec_with(2.0 - margins[0].1, 3.0 - margins[1].1));
    assert_eq!(p.qp.rows.upper, moved.upper);
}

fn spec_with(x_max: f64, upper: f64) -> String {
    spec(
        &format!("x_max = [{x_max:?}, inf]"),
        &format!("upper = [{upper:?}]"),
    )
}

#[test]
fn a_margin_that_empties_a_bound_is_an_error_at_its_key() {
    let src = spec(
        "x_min = [-0.2, -inf]\nx_max = [0.2, inf]\nx_backoff = [0.3, 0]",
        "upper = [3]",
    );
    let diags = uncertified(&load(&src).unwrap()).expect_err("emptied");
    let d = diags.iter().next().unwrap();
    assert!(d.message.contains("x_min/x_max[0]"), "{}", d.message);
    assert_eq!(&src[d.span.clone().unwrap()], "0.3");
    // Hard rows that admit no stage once pulled in: x ≤ 0.2 − 0 and x + v + u/2 ≥ 1 + 2 with |v| ≤ 1.
    let src = spec(
        "x_max = [0.2, 1]\nx_min = [-inf, -1]",
        "lower = [1.2]\nbackoff = 0.6",
    );
    let diags = uncertified(&load(&src).unwrap()).expect_err("no stage");
    let d = diags.iter().next().unwrap();
    assert!(d.message.contains("admit no state"), "{}", d.message);
    assert!(d.note.as_deref().unwrap().contains("backoff"));
}
