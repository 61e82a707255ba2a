//! The Riccati form of the interior-point method's normal system (`codegen::riccati`): its solve equals
//! the dense solve of (H + Gᵀ·diag(d)·G)·Δz = r, the iterates of the method in either form agree, and
//! the problems it is not built for are refused with the reason.
#![allow(non_snake_case)]

use codegen::ipm::{self, mpc_qp, Layout, Start};
use codegen::lower::Qp;
use codegen::riccati::{Choice, Form, Stages};
use nalgebra::{DMatrix, DVector};

/// specs/hover.toml with `method = "ipm"` (its `auto` picks the dual active set).
const HOVER: &str = include_str!("../../tests/specs/ipm/hover.toml");

/// A double integrator with a state bound, a row on (x_k, u_k) and a row on x_{k+1} only, so that the
/// stage Hessians have their cross terms S̃_k:
///   x_{k+1} = [1 0.1; 0 1]·x_k + [0.005; 0.1]·u_k, |v| ≤ 2, −3 ≤ p + ½u ≤ 3, −4 ≤ p + v ≤ 4.
const SMALL: &str = r#"
[model]
type = "linear"
dt = 0.1
a = [[1.0, 0.1], [0.0, 1.0]]
b = [[0.005], [0.1]]

[mpc]
horizon = 6
method = "ipm"
iterations = 12
q = [1.0, 0.1]
r = [0.1]
u_min = [-1.0]
u_max = [1.0]
x_min = [-inf, -2.0]
x_max = [inf, 2.0]

[[mpc.constraint]]
ax = [[1.0, 0.0]]
au = [[0.5]]
lower = [-3.0]
upper = [3.0]

[[mpc.constraint]]
ax = [[1.0, 1.0]]
lower = [-4.0]
upper = [4.0]

[mpc.region]
x_min = [-1.0, -1.0]
x_max = [1.0, 1.0]
"#;

/// SMALL with soft rows: the velocity bounds (one slack per component, shared by every stage and both
/// sides) and the row on x_{k+1} (its own slack), so that the normal system has the slacks' block.
fn soft() -> String {
    SMALL
        .replace("x_max = [inf, 2.0]", "x_max = [inf, 2.0]\nx_soft = 100.0")
        .replace("upper = [4.0]", "upper = [4.0]\nsoft = 50.0")
}

fn problem(src: &str) -> codegen::Problem {
    let src = src.replace("iterations = \"auto\"", "iterations = 20");
    codegen::lower(&mpc_spec::load(&src).unwrap()).unwrap()
}

fn qp(src: &str) -> Qp {
    problem(src).qp
}

/// A deterministic stream of numbers in [0, 1) (an LCG).
struct Stream(u64);

impl Stream {
    fn next(&mut self) -> f64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// H + Gᵀ·diag(d)·G of the MPC's QP, dense, for the sides of `layout`.
fn normal(problem: &ipm::InequalityQp, layout: &Layout, d: &DVector<f64>) -> DMatrix<f64> {
    let mut M = problem.H.clone();
    for (k, &(i, _)) in layout.boxed.iter().enumerate() {
        M[(i, i)] += d[k];
    }
    let nb = layout.boxed.len();
    for (k, &(r, _)) in layout.rows.iter().enumerate() {
        let a = problem.A.row(r).transpose();
        M += &a * a.transpose() * d[nb + k];
    }
    M
}

/// The Riccati solve against nalgebra's Cholesky solve of the dense normal matrix, on weights spread
/// over eight orders of magnitude (λ/s near a solution spans more; these keep κ(M) where a 1e-9
/// agreement is a statement about the method, not about rounding).
fn solves_agree(name: &str, src: &str, seed: u64) {
    let qp = qp(src);
    let stages = Stages::of(&qp).unwrap_or_else(|e| panic!("{name}: {e}"));
    let problem = mpc_qp(
        &qp,
        &DVector::zeros(qp.N * qp.u_min.len()),
        &DVector::zeros(qp.rows.len()),
    );
    let n = problem.n();
    let layout = Layout::of(&problem);
    assert!(!layout.rows.is_empty(), "{name}: the test needs rows");
    let mut stream = Stream(seed);
    let mut worst: f64 = 0.0;
    for _ in 0..20 {
        let d = DVector::from_fn(layout.boxed.len() + layout.rows.len(), |_, _| {
            10f64.powf(8.0 * stream.next() - 4.0)
        });
        let r = DVector::from_fn(n, |_, _| 2.0 * stream.next() - 1.0);
        let dense = normal(&problem, &layout, &d).cholesky().unwrap().solve(&r);
        let f = stages.factor(&layout.boxed, &layout.rows, &d, 0.0).unwrap();
        let riccati = f.solve(&r);
        let e = (&riccati - &dense).amax() / dense.amax();
        worst = worst.max(e);
        assert!(e <= 1e-9, "{name}: relative difference {e:e}");
    }
    println!("{name}: the Riccati solve within {worst:.1e} of the dense one (relative)");
}

#[test]
fn the_riccati_solve_is_the_dense_solve_of_the_normal_system() {
    solves_agree("hover", HOVER, 1);
    solves_agree("small", SMALL, 2);
    let soft = soft();
    assert_eq!(qp(&soft).rows.slacks(), 2);
    solves_agree("small, soft", &soft, 3);
}

/// The fixed-iteration method in both forms, cold and then warm along a closed loop: the same iterates
/// to rounding (1e-9 of the input span on the plan).
#[test]
fn the_method_gives_the_same_iterates_in_either_form() {
    let soft = soft();
    for (name, src) in [("hover", HOVER), ("small", SMALL), ("small, soft", &soft)] {
        let p = problem(src);
        let qp = p.qp.clone();
        let stages = Stages::of(&qp).unwrap();
        let nu = qp.u_min.len();
        let nx = qp.Sx.ncols();
        let mut stream = Stream(7);
        let mut worst: f64 = 0.0;
        for case in 0..10 {
            // States inside half of the bounds' range and a reference offset.
            let x0 = DVector::from_fn(nx, |_, _| 1.0 * (2.0 * stream.next() - 1.0));
            let xref: Vec<DVector<f64>> = (0..qp.N)
                .map(|_| DVector::from_fn(qp.nz, |_, _| 0.5 * (2.0 * stream.next() - 1.0)))
                .collect();
            let mpc = codegen::oracle::Mpc::new(&p);
            let f = mpc.linear_term(&x0, &xref);
            let offset = qp.rows.offset(&x0, &DVector::zeros(0), &qp.rest_input());
            let problem = mpc_qp(&qp, &f, &offset);
            for iterations in [1, 5, 12] {
                let a = ipm::solve_fixed_in(&problem, &Start::Cold, iterations, None);
                let b = ipm::solve_fixed_in(&problem, &Start::Cold, iterations, Some(&stages));
                assert_eq!(a.status, b.status, "{name} case {case}");
                assert_eq!(a.iterations, b.iterations, "{name} case {case}");
                for i in 0..qp.N * nu {
                    let span = qp.u_max[i % nu] - qp.u_min[i % nu];
                    let e = (a.z[i] - b.z[i]).abs() / span;
                    worst = worst.max(e);
                    assert!(e <= 1e-9, "{name} case {case} at {iterations}: {e:e}");
                }
            }
        }
        println!("{name}: the two forms' plans within {worst:.1e} of the span");
    }
}

/// What the Riccati form is not built for is refused with the reason, and the cost model then keeps the
/// condensed form.
#[test]
fn unsupported_problems_keep_the_condensed_form() {
    let afti = qp(include_str!("../../specs/afti16.toml"));
    let why = Stages::of(&afti).unwrap_err();
    assert!(why.contains("r_du"), "{why}");
    let c = Choice::of(&afti);
    assert_eq!(c.form, Form::Condensed);
    assert!(c.riccati_macs_per_iteration.is_none() && c.riccati_unavailable.is_some());
    let moves = SMALL.replace(
        "u_max = [1.0]",
        "u_max = [1.0]\ndu_min = [-0.5]\ndu_max = [0.5]",
    );
    let why = Stages::of(&qp(&moves)).unwrap_err();
    assert!(why.contains("move bounds"), "{why}");
    let weighted = SMALL.replace("r = [0.1]", "r = [0.1]\nr_du = 0.2");
    let why = Stages::of(&qp(&weighted)).unwrap_err();
    assert!(why.contains("r_du"), "{why}");
}

/// The cost model's counts: hover's Riccati form is the cheaper, and the chosen count is the method's.
#[test]
fn the_cost_model_weighs_both_forms() {
    let hover = qp(HOVER);
    let c = Choice::of(&hover);
    println!("hover: {c:?}");
    let riccati = c.riccati_macs_per_iteration.unwrap();
    assert!(riccati < c.condensed_macs_per_iteration, "{c:?}");
    assert_eq!(c.form, Form::Riccati);
    assert_eq!(ipm::mpc_macs_per_iteration(&hover), riccati);
    assert_eq!(ipm::riccati_macs_per_iteration(&hover), Some(riccati));
    assert_eq!(
        ipm::condensed_macs_per_iteration(&hover),
        c.condensed_macs_per_iteration
    );
}

/// The emitted module carries the chosen form's kernels only: hover's the Riccati recursion in place of
/// the envelope's L·D·Lᵀ (whose kernels and tables are gone), the quadcopter's the envelope's.
#[test]
fn the_emitted_module_has_the_chosen_forms_kernels() {
    let emitted = |src: &str| {
        codegen::generate_from_source(src, &codegen::Opt::default())
            .unwrap()
            .tokens
            .to_string()
    };
    let count = |code: &str, item: &str| code.matches(item).count();
    let hover = emitted(HOVER);
    for (item, n) in [
        ("fn factor (", 1),
        ("fn ldl_solve (", 1),
        ("fn riccati (", 1),
        ("struct NormalFactor", 1),
        ("fn ldl (", 0),
        ("const FIRST :", 0),
        ("const REACH :", 0),
    ] {
        assert_eq!(count(&hover, item), n, "hover: `{item}`");
    }
    let quadcopter = emitted(include_str!("../../tests/specs/ipm/quadcopter.toml"));
    for (item, n) in [
        ("fn factor (", 1),
        ("fn ldl (", 1),
        ("fn ldl_solve (", 1),
        ("type NormalFactor", 1),
        // Its forming and L·D·Lᵀ are written out within their budgets: no envelope tables.
        ("fn form (", 1),
        ("const FIRST :", 0),
        ("fn riccati (", 0),
    ] {
        assert_eq!(count(&quadcopter, item), n, "quadcopter: `{item}`");
    }
}
