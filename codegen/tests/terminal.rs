//! `qf = "lqr"`: the terminal weight from the discrete algebraic Riccati equation, checked against a second
//! method (the Riccati recursion iterated to convergence), in the lowered QP, and in the stability
//! certificate of the pendulum on a cart that needs it.
#![allow(non_snake_case)]

use codegen::certificate::certify;
use codegen::linalg::dare;
use codegen::lower::uncertified;
use codegen::{lower, plan};
use mpc_spec::load;
use nalgebra::DMatrix;

const PENDULUM: &str = include_str!("../../tests/specs/pendulum-lqr.toml");

/// The Riccati recursion P ← Q + AᵀPA − (AᵀPB + S)(R + BᵀPB)⁻¹(BᵀPA + Sᵀ) from P = Q, iterated until
/// it stops changing: the second, independent method.
fn recursion(
    A: &DMatrix<f64>,
    B: &DMatrix<f64>,
    Q: &DMatrix<f64>,
    R: &DMatrix<f64>,
    S: &DMatrix<f64>,
) -> DMatrix<f64> {
    let mut P = Q.clone();
    for _ in 0..10_000_000 {
        let M = A.transpose() * &P * B + S;
        let K = (R + B.transpose() * &P * B)
            .cholesky()
            .unwrap()
            .solve(&M.transpose());
        let next = Q + A.transpose() * &P * A - &M * K;
        let next = (&next + next.transpose()) * 0.5;
        if (&next - &P).amax() <= 1e-15 * next.amax() {
            return next;
        }
        P = next;
    }
    panic!("the recursion did not converge");
}

/// The sampled pendulum (F, G) of the spec.
fn pendulum() -> (DMatrix<f64>, DMatrix<f64>) {
    let spec = load(PENDULUM).unwrap();
    let p = uncertified(&spec).unwrap();
    (p.F, p.G)
}

fn relative(a: &DMatrix<f64>, b: &DMatrix<f64>) -> f64 {
    (a - b).amax() / b.amax()
}

#[test]
fn dare_agrees_with_the_recursion() {
    let (F, G) = pendulum();
    let Q = DMatrix::from_diagonal(&nalgebra::dvector![1.44, 0.0, 1.0, 0.0]);
    let R = DMatrix::from_element(1, 1, 0.5);
    let S = DMatrix::zeros(4, 1);
    let P = dare(&F, &G, &Q, &R, &S).unwrap();
    let reference = recursion(&F, &G, &Q, &R, &S);
    let e = relative(&P, &reference);
    assert!(e < 1e-9, "DARE vs recursion: {e:e}");
    // And it solves the equation.
    let M = F.transpose() * &P * &G;
    let residual = &Q + F.transpose() * &P * &F
        - &M * (&R + G.transpose() * &P * &G)
            .cholesky()
            .unwrap()
            .solve(&M.transpose())
        - &P;
    assert!(residual.amax() < 1e-9 * P.amax(), "{:e}", residual.amax());
}

#[test]
fn dare_with_a_cross_term_agrees_with_the_recursion() {
    // The pendulum augmented with u₋₁ as the lowering builds it for `r_du`: cross term [0; R].
    let (F, G) = pendulum();
    let mut A = DMatrix::zeros(5, 5);
    A.view_mut((0, 0), (4, 4)).copy_from(&F);
    A.view_mut((0, 4), (4, 1)).copy_from(&G);
    A[(4, 4)] = 1.0;
    let mut B = DMatrix::zeros(5, 1);
    B.view_mut((0, 0), (4, 1)).copy_from(&G);
    B[(4, 0)] = 1.0;
    let Q = DMatrix::from_diagonal(&nalgebra::dvector![1.44, 0.0, 1.0, 0.0, 0.3]);
    let mut S = DMatrix::zeros(5, 1);
    S[(4, 0)] = 0.3;
    let R = DMatrix::from_element(1, 1, 1.3);
    let P = dare(&A, &B, &Q, &R, &S).unwrap();
    let e = relative(&P, &recursion(&A, &B, &Q, &R, &S));
    assert!(e < 1e-9, "DARE vs recursion: {e:e}");
}

#[test]
fn an_unstabilizable_plant_has_no_solution() {
    // An unstable mode the input does not reach.
    let A = DMatrix::from_row_slice(2, 2, &[1.1, 0.0, 0.0, 0.5]);
    let B = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
    let Q = DMatrix::identity(2, 2);
    let R = DMatrix::identity(1, 1);
    assert!(dare(&A, &B, &Q, &R, &DMatrix::zeros(2, 1)).is_none());
}

/// The lowered QP with `qf = "lqr"` is the one with `qf` written as the augmented recursion's P_xx.
#[test]
fn the_lowered_terminal_weight_is_the_augmented_riccati_state_block() {
    let (F, G) = pendulum();
    let mut A = DMatrix::zeros(5, 5);
    A.view_mut((0, 0), (4, 4)).copy_from(&F);
    A.view_mut((0, 4), (4, 1)).copy_from(&G);
    A[(4, 4)] = 1.0;
    let mut B = DMatrix::zeros(5, 1);
    B.view_mut((0, 0), (4, 1)).copy_from(&G);
    B[(4, 0)] = 1.0;
    // Q = C_zᵀ diag(1.44, 1) C_z, R = 0, R_du = 1: Q_ξ = blkdiag(Q, 0), S = 0, input weight 1.
    let Q = DMatrix::from_diagonal(&nalgebra::dvector![1.44, 0.0, 1.0, 0.0, 0.0]);
    let P = recursion(&A, &B, &Q, &DMatrix::identity(1, 1), &DMatrix::zeros(5, 1));
    let rows: Vec<String> = (0..4)
        .map(|i| {
            let row: Vec<String> = (0..4).map(|j| format!("{:e}", P[(i, j)])).collect();
            format!("[{}]", row.join(", "))
        })
        .collect();
    let written = PENDULUM.replace("qf = \"lqr\"", &format!("qf = [{}]", rows.join(", ")));
    assert_ne!(written, PENDULUM);
    let lqr = uncertified(&load(PENDULUM).unwrap()).unwrap().qp;
    let given = uncertified(&load(&written).unwrap()).unwrap().qp;
    let (eH, eFx) = (relative(&lqr.H, &given.H), relative(&lqr.Fx, &given.Fx));
    assert!(eH < 1e-9 && eFx < 1e-9, "H {eH:e}, Fx {eFx:e}");
    let eFr = relative(&lqr.Fr, &given.Fr);
    assert!(eFr < 1e-9, "Fr {eFr:e}");
}

/// The pendulum at N = 10 without a control horizon: unstable with Qf = Q (ρ = 1.0228), stable with the
/// Riccati terminal weight (ρ = 0.9726), in the stability certificate.
#[test]
fn the_riccati_terminal_weight_stabilizes_the_pendulum() {
    let radius = |src: &str| {
        let spec = load(src).unwrap();
        let p = lower(&spec).unwrap();
        certify(&p, &plan(&spec, &p).unwrap()).mpc.spectral_radius
    };
    let with = radius(PENDULUM);
    let without = radius(&PENDULUM.replace("qf = \"lqr\"", "accept_unstable = true"));
    eprintln!("ρ with qf = \"lqr\": {with:.4}, with Qf = Q: {without:.4}");
    assert!(with < 1.0, "{with}");
    assert!(without > 1.0, "{without}");
}
