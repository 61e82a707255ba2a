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
fn debug_stall() {
    use codegen::ipm::*;
    use nalgebra::DVector;
    let Ok(text) = std::fs::read_to_string("/tmp/pl_1e4.toml") else {
        return;
    };
    let mut spec = mpc_spec::load(&text).unwrap();
    spec.mpc.iterations = mpc_spec::Iterations::Fixed(20);
    let p = codegen::lower(&spec).unwrap();
    let qp = &p.qp;
    let x0 = DVector::from_vec(vec![
        -4.310226894718191,
        9.309832979083481,
        7.453580386041817,
        2.970445582084357,
        -2.7028752090439765,
        1.4909262447842864,
    ]);
    let r = DVector::from_vec(vec![
        0.38845574505576685,
        0.6098273055917902,
        8.017065425355336,
        -2.414200370618728,
        -2.7238415837622894,
        1.0961748188415994,
    ]);
    let Xref = DVector::from_fn(qp.N * 6, |i, _| r[i % 6]);
    let last = qp.rest_input();
    let f = &qp.Fx * &x0 - &qp.Fr * Xref;
    let off = qp.rows.offset(&x0, &DVector::zeros(0), &last);
    let prob = mpc_qp(qp, &f, &off);
    let run = trajectory(&prob, &Start::Cold, 60);
    for r in &run {
        let smin = r.s.iter().cloned().fold(f64::INFINITY, f64::min);
        let lmax = r.lambda.amax();
        eprintln!(
            "{} {:?} p {:.2e} d {:.2e} gap {:.2e} compl {:.2e} smin {:.2e} lmax {:.2e} slack {:?}",
            r.iterations,
            r.status,
            r.primal_residual,
            r.dual_residual,
            r.gap,
            r.complementarity,
            smin,
            lmax,
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
