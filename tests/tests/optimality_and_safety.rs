//! With enough iterations the generated solver reaches the exact optimum of the box-constrained QP
//! (KKT conditions), and whatever it is fed, its command is finite and inside the box.
#![allow(non_snake_case)]

use codegen::oracle;
use mpc_tests::generated::*;
use mpc_tests::harness::*;
use nalgebra::DVector;

/// The KKT conditions of min ½UᵀHU + fᵀU over the box: ∇J = HU + f vanishes where U is strictly inside,
/// is ≥ 0 where U sits on its lower bound and ≤ 0 on its upper bound.
#[test]
fn many_iterations_reach_the_exact_qp_optimum() {
    let p = converged::problem();
    let qp = &p.qp;
    let (nx, nu, N) = (p.nx, p.nu, qp.N);
    let oracle = oracle::Mpc::new(&p);
    let mut generated = converged::mpc_new();
    let mut rng = rng(11);
    let (mut lower, mut upper, mut inside) = (0, 0, 0);
    for run in 0..60 {
        let scale = [0.05, 0.5, 5.0][run % 3];
        let x0 = random_vector(&mut rng, nx, scale);
        let center = random_vector(&mut rng, nx, scale);
        let xref: Vec<DVector<f64>> = (0..N)
            .map(|_| &center + random_vector(&mut rng, nx, 0.1 * scale))
            .collect();
        let xref_vec: Vec<Vec<f64>> = xref.iter().map(|r| r.iter().copied().collect()).collect();
        converged::mpc_reset(&mut generated);
        converged::mpc_solve(&mut generated, x0.as_slice(), &xref_vec);
        let U = DVector::from_vec(converged::mpc_plan(&generated));
        let f = oracle.linear_term(&x0, &xref);
        let g = &qp.H * &U + &f;
        let tol = 1e-9 * (1.0 + f.amax());
        for i in 0..N * nu {
            let (lo, hi) = (qp.u_min[i % nu], qp.u_max[i % nu]);
            if U[i] == lo {
                lower += 1;
                assert!(g[i] >= -tol, "∇J = {} < 0 at a lower bound", g[i]);
            } else if U[i] == hi {
                upper += 1;
                assert!(g[i] <= tol, "∇J = {} > 0 at an upper bound", g[i]);
            } else {
                inside += 1;
                assert!(
                    g[i].abs() <= tol,
                    "∇J = {} ≠ 0 strictly inside the box",
                    g[i]
                );
            }
        }
        let exact = oracle::exact_solution(qp, &f, 1e-13, 100_000);
        assert!((&U - &exact).amax() <= 1e-8 * (1.0 + exact.amax()));
        assert!(oracle::kkt_residual(qp, &f, &U) <= tol);
    }
    assert!(
        lower > 0 && upper > 0 && inside > 0,
        "cases: {lower} lower, {upper} upper, {inside} inside"
    );
}

/// Non-finite states or references give the rest input and reset the warm start.
#[test]
fn non_finite_state_gives_the_rest_input_and_resets() {
    use mpc_tests::asymmetric_gradient::{Mpc, N, NX, U_REST};
    let mut mpc = Mpc::new();
    let xref = [[1.0; NX]; N];
    mpc.solve(&[0.0; NX], &xref);
    assert_ne!(mpc, Mpc::new());
    for bad in [f64::NAN, f64::INFINITY] {
        let mut x0 = [0.0; NX];
        x0[2] = bad;
        assert_eq!(mpc.solve(&x0, &xref), U_REST);
        assert_eq!(mpc, Mpc::new());
        let mut r = xref;
        r[N - 1][0] = bad;
        mpc.solve(&[0.0; NX], &xref);
        assert_eq!(mpc.solve(&[0.0; NX], &r), U_REST);
        assert_eq!(mpc, Mpc::new());
    }
    // The rest input is zero projected onto this spec's box, whose z range excludes zero.
    assert_eq!(U_REST, [0.0, 0.0, 0.5]);
}

/// Extreme but finite inputs overflow f32 arithmetic inside the solver; the command stays finite and in the box.
#[test]
fn extreme_inputs_give_finite_commands_inside_the_box() {
    use mpc_tests::paper::{Controller, Mpc, N, NX, U_MAX, U_MIN};
    let mut mpc = Mpc::new();
    let mut rng = rng(3);
    for k in 0..2000 {
        let magnitude = [1e-30, 1.0, 1e10, 1e30, f32::MAX][k % 5];
        let x0: [f32; NX] =
            core::array::from_fn(|_| magnitude * (rand::Rng::gen_range(&mut rng, -1.0..1.0)));
        let xref: [[f32; NX]; N] = core::array::from_fn(|_| {
            core::array::from_fn(|_| magnitude * rand::Rng::gen_range(&mut rng, -1.0..1.0))
        });
        let u = mpc.solve(&x0, &xref);
        for j in 0..3 {
            assert!(
                u[j].is_finite() && u[j] >= U_MIN[j] && u[j] <= U_MAX[j],
                "u = {u:?} for |x| ~ {magnitude}"
            );
        }
        assert!(mpc.plan().iter().flatten().all(|v| v.is_finite()));
    }
    let mut c = Controller::new([0.0; NX]);
    for _ in 0..100 {
        let u = c.step(&[f32::MAX, -f32::MAX, f32::NAN], &[[f32::MAX; NX]; N]);
        assert!(u
            .iter()
            .zip(U_MIN.iter().zip(U_MAX.iter()))
            .all(|(u, (lo, hi))| u.is_finite() && u >= lo && u <= hi));
    }
}

/// The generated matrices are the library's, rounded once to the scalar type.
#[test]
fn emitted_constants_are_the_lowered_matrices() {
    let p = paper::problem();
    for (i, row) in mpc_tests::paper::H.iter().enumerate() {
        for (j, h) in row.iter().enumerate() {
            assert_eq!(*h, p.qp.H[(i, j)] as f32);
        }
    }
    let p = linear_f64::problem();
    for (i, row) in mpc_tests::linear_f64::FX.iter().enumerate() {
        for (j, v) in row.iter().enumerate() {
            assert_eq!(*v, p.qp.Fx[(i, j)]);
        }
    }
    assert_eq!(mpc_tests::paper::STEP, (1.0 / paper::problem().qp.L) as f32);
    assert_eq!(mpc_tests::paper_faithful::STEP, 0.04);
    assert_eq!(mpc_tests::paper_faithful::MOMENTUM, 0.0);
}
