//! The constraints of issue 17 lowered and solved: rows against the prediction, the interior-point
//! method's certificate against Clarabel.
#![allow(non_snake_case)]

use mpc_spec::{Constraints, Method, Region};

/// specs/paper.toml with |v| ≤ 2 per axis and z ≥ 0 (soft), solved by the interior-point method.
pub fn paper_limits() -> mpc_spec::Spec {
    let mut spec = mpc_spec::load(include_str!("../../specs/paper.toml")).unwrap();
    let inf = f64::INFINITY;
    spec.mpc.method = Method::Ipm;
    spec.mpc.iterations = mpc_spec::Iterations::Auto;
    spec.mpc.constraints = Constraints {
        x_min: vec![-inf, -inf, 0.0, -2.0, -2.0, -2.0],
        x_max: vec![inf, inf, inf, 2.0, 2.0, 2.0],
        x_soft: Some(1e4),
        ..Default::default()
    };
    spec.mpc.region = Region {
        x_min: vec![-3.0, -3.0, 0.0, -2.0, -2.0, -2.0],
        x_max: vec![3.0, 3.0, 3.0, 2.0, 2.0, 2.0],
        ..Default::default()
    };
    spec
}

#[test]
fn paper_limits_is_certified() {
    let spec = paper_limits();
    let t = std::time::Instant::now();
    let p = codegen::lower(&spec).unwrap();
    let e = p.qp.evidence.as_ref().unwrap();
    eprintln!("{:#?} in {:?}", e, t.elapsed());
    eprintln!(
        "rows {} per slot {} slacks {}",
        p.qp.rows.len(),
        p.qp.rows.per_slot,
        p.qp.rows.slacks()
    );
}

#[test]
fn debug_corner() {
    use codegen::ipm::*;
    use nalgebra::DVector;
    let mut spec = paper_limits();
    spec.mpc.iterations = mpc_spec::Iterations::Fixed(20);
    spec.mpc.method = Method::Fgm;
    let p = codegen::lower(&spec).unwrap();
    let qp = &p.qp;
    let x0 = DVector::from_vec(vec![-3.0, 3.0, 0.0, 2.0, -2.0, -2.0]);
    let r = DVector::from_vec(vec![1.0, 1.0, 1.0, 0.0, 0.0, 0.0]);
    let Xref = DVector::from_fn(qp.N * 6, |i, _| r[i % 6]);
    let last = qp.rest_input();
    let f = &qp.Fx * &x0 - &qp.Fr * Xref;
    let off = qp.rows.offset(&x0, &DVector::zeros(0), &last);
    let prob = mpc_qp(qp, &f, &off);
    let exact = solve(&prob, 1e-10, 200);
    eprintln!(
        "exact {:?} it {} res {} {} gap {} compl {}",
        exact.status,
        exact.iterations,
        exact.primal_residual,
        exact.dual_residual,
        exact.gap,
        exact.complementarity
    );
    let run = trajectory(&prob, &Start::Cold, 60);
    for r in &run {
        let e = (&r.z - &exact.z).rows(0, 45).amax();
        eprintln!(
            "{} {:?} err {:.3e} p {:.2e} d {:.2e} gap {:.2e} slack {:?}",
            r.iterations,
            r.status,
            e,
            r.primal_residual,
            r.dual_residual,
            r.gap,
            r.z.rows(45, r.z.len() - 45).as_slice()
        );
    }
}

#[test]
fn dump_paper_limits() {
    let spec = paper_limits();
    let g = codegen::generate(&spec, &codegen::Opt::default()).unwrap();
    std::fs::write("/tmp/paper_limits.rs", g.tokens.to_string()).unwrap();
}
