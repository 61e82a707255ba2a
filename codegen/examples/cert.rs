fn main() {
    for path in std::env::args().skip(1) {
        let src = std::fs::read_to_string(&path).unwrap();
        let p = codegen::lower(&mpc_spec::load(&src).unwrap()).unwrap();
        let c = codegen::certificate::certify(&p);
        println!("{path}: L {} mu {} cond {} step {} beta {} contraction {} iters {} bound {:?} gap {:?}", c.lipschitz, c.strong_convexity, c.condition_number, c.step, c.momentum, c.contraction, c.iterations, c.iterations_bound, c.guaranteed_gap);
        println!(
            "  lqr rho {} lyap {} {}  mpc rho {} solver {:?}",
            c.lqr.spectral_radius,
            c.lqr.lyapunov_min,
            c.lqr.lyapunov_max,
            c.mpc.spectral_radius,
            c.mpc.solver_spectral_radius
        );
        println!(
            "  {:?} tau_d {:?}",
            c.resources, c.disturbance_time_constant
        );
    }
}
