//! The exact reference (`codegen::exact`) on a feasible QP the interior-point method alone does not
//! solve: a double integrator with a hard speed limit (found by a seeded search over 3,000 draws of
//! far references; Clarabel solves it, and the KKT conditions are checked here independently).
#![allow(non_snake_case)]

use codegen::exact::{exact_by, Solver};
use codegen::ipm::{mpc_qp, solve, Layout};
use codegen::solver::Status;
use nalgebra::DVector;

const SPEC: &str = r#"
[model]
type = "double_integrator"
axes = 1
dt = 0.05
[mpc]
horizon = 30
method = "ipm"
iterations = "auto"
q = [100.0, 1]
r = [0.01]
u_min = [-1]
u_max = [1]
x_min = [-inf, -0.5]
x_max = [inf, 0.5]
[mpc.region]
x_min = [-10, -0.5]
x_max = [10, 0.5]
samples = 0
sequences = 0
steps = 1
"#;

/// The reference's positions, one per step (velocities 0).
const POSITIONS: [f64; 30] = [
    614.0879112147136,
    523.050866059092,
    -801.7796145368195,
    420.54779296606876,
    180.35808032102796,
    -895.8062379336238,
    -569.7821024595662,
    608.8385462515521,
    -143.24052130148516,
    -355.86218378087415,
    -486.3773183303555,
    -498.16271945035686,
    -97.10032615486239,
    641.7044666965505,
    114.18297592717954,
    -837.8167785277917,
    -337.1847400861893,
    -504.2013537381389,
    -457.11105746104727,
    317.8779900763077,
    -2.2261757609536517,
    555.3253129774394,
    832.9021139849631,
    -318.1605470684583,
    969.7836981871535,
    -400.00673503652445,
    -51.74282602836524,
    269.72855892960456,
    186.9228970989418,
    -391.06303628095554,
];
const X0: [f64; 2] = [-11.485217850347107, 0.21772869524300753];

#[test]
fn a_feasible_qp_the_interior_point_method_fails_on_is_solved_by_the_exact_reference() {
    let spec = mpc_spec::load(SPEC).expect("spec");
    let p = codegen::lower(&spec).expect("lowered");
    let qp = &p.qp;
    let x0 = DVector::from_column_slice(&X0);
    let reference = DVector::from_fn(2 * POSITIONS.len(), |i, _| {
        if i % 2 == 0 {
            POSITIONS[i / 2]
        } else {
            0.0
        }
    });
    let last = qp.rest_input();
    let f = &qp.Fx * &x0 - &qp.Fr * &reference + &qp.Fu * &last;
    let offset = qp.rows.offset(&x0, &DVector::zeros(0), &last);
    let problem = mpc_qp(qp, &f, &offset);
    // The case is one the interior-point method alone does not solve (if it now does, this test
    // checks nothing: find another with the search described above).
    let alone = solve(
        &problem,
        codegen::exact::EXACT_TOLERANCE,
        codegen::exact::EXACT_ITERATIONS,
    );
    assert_eq!(alone.status, Status::NumericalFailure);
    let (r, by) = exact_by(&problem);
    assert_eq!((r.status, by), (Status::Converged, Solver::Clarabel));
    // KKT, checked here: primal feasibility, λ ≥ 0, stationarity H z + f + Gᵀλ = 0, complementarity.
    let z = &r.z;
    let layout = Layout::of(&problem);
    let mut Gt_lambda = DVector::zeros(problem.n());
    let mut worst_violation = 0.0_f64;
    let mut worst_complementarity = 0.0_f64;
    let sides = layout.boxed.iter().map(|&(i, sign)| {
        let mut g = DVector::zeros(problem.n());
        g[i] = sign;
        (
            g,
            if sign > 0.0 {
                problem.z_max[i]
            } else {
                -problem.z_min[i]
            },
        )
    });
    let rows = layout.rows.iter().map(|&(k, sign)| {
        (
            problem.A.row(k).transpose() * sign,
            if sign > 0.0 {
                problem.upper[k]
            } else {
                -problem.lower[k]
            },
        )
    });
    for (k, (g, h)) in sides.chain(rows).enumerate() {
        let lambda = r.lambda[k];
        assert!(lambda >= -1e-9, "side {k}: multiplier {lambda}");
        let slack = h - g.dot(z);
        worst_violation = worst_violation.max(-slack);
        worst_complementarity = worst_complementarity.max((lambda * slack).abs());
        Gt_lambda += g * lambda;
    }
    let stationarity = (&problem.H * z + &problem.f + Gt_lambda).amax();
    let scale = 1.0 + problem.f.amax();
    println!(
        "violation {worst_violation:.1e}, stationarity {:.1e} (of ‖f‖), complementarity {worst_complementarity:.1e}",
        stationarity / scale
    );
    assert!(worst_violation <= 1e-7, "violation {worst_violation}");
    assert!(stationarity <= 1e-6 * scale, "stationarity {stationarity}");
    assert!(
        worst_complementarity <= 1e-6 * scale,
        "complementarity {worst_complementarity}"
    );
}
