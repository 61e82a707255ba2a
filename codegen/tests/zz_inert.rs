use codegen::oracle::Mpc;
use nalgebra::DVector;
fn run(src: &str, x0: DVector<f64>, refv: DVector<f64>, steps: usize) {
    let spec = mpc_spec::load(src).unwrap();
    let p = codegen::lower(&spec).unwrap();
    let mut m = Mpc::new(&p);
    let mut x = x0;
    let xref = vec![refv; p.qp.N];
    for k in 0..steps {
        let u = m.solve(&x, &xref);
        let s = m.last_step().map(|s| {
            (
                s.fallback,
                s.result.status,
                s.result.primal_residual,
                s.result.dual_residual,
                s.result.relative_gap,
                s.result.iterations,
            )
        });
        x = &p.F * &x + &p.G * &u;
        if k % (steps / 20).max(1) == 0 {
            println!(
                "k {k} x {:?} u {:?} {:?}",
                x.as_slice()
                    .iter()
                    .map(|v| format!("{v:.2}"))
                    .collect::<Vec<_>>(),
                u.as_slice()
                    .iter()
                    .map(|v| format!("{v:.2}"))
                    .collect::<Vec<_>>(),
                s
            );
        }
    }
}
#[test]
fn far() {
    let mut r = DVector::zeros(6);
    r[0] = 1e6;
    run(
        include_str!("../../specs/paper-limits.toml"),
        DVector::zeros(6),
        r,
        400,
    );
}
#[test]
fn phi() {
    let mut x = DVector::zeros(12);
    x[0] = 1.5;
    run(
        include_str!("../../specs/quadcopter.toml"),
        x,
        DVector::zeros(12),
        60,
    );
    let mut x = DVector::zeros(12);
    x[5] = -50.0;
    run(
        include_str!("../../specs/quadcopter.toml"),
        x,
        DVector::zeros(12),
        60,
    );
}
