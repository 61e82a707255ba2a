// A horizon of 100 compiles (the limit is `mpc_spec::MAX_HORIZON` = 250), and the controller acts on it.
// One axis keeps the unrolled 100 × 100 Hessian product small enough for a quick test build; the paper's
// three axes at N = 100 (a 300 × 300 product) are built by the benchmarks (`tests/benches/specs/paper-n100.toml`).
mpc_macros::mpc!(mod long_horizon {
    r#"
    [model]
    type = "double_integrator"
    axes = 1
    dt = 0.02

    [mpc]
    horizon = 100
    iterations = 20
    # What 20 iterations guarantee at N = 100 (a gap ratio of 0.36); the default 1e-4 would need 116.
    tolerance = 0.37
    q = [10, 1]
    r = [0.1]
    u_min = [-5]
    u_max = [5]

    [kalman]
    sigma_a = 0.5
    sigma_meas = 0.1
    filter = "steady_state"
    "#
});

fn main() {
    assert_eq!(long_horizon::N, 100);
    let mut controller = long_horizon::Controller::new([0.0; long_horizon::NX]);
    let xref = [[1.0, 0.0]; long_horizon::N];
    let u = controller.step(&[0.0; long_horizon::NY], &xref);
    assert!(u[0] > 0.0 && u[0] <= long_horizon::U_MAX[0]);
}
