// Two controllers in one module whose specs both warn (two iterations miss the default tolerance): each
// warning is a deprecated item in an anonymous const of its own, so they build side by side (they used to
// collide as two `__mpc_spec_warning_0`).
mpc_macros::mpc!(mod first {
    r#"
    [model]
    type = "double_integrator"
    axes = 1
    dt = 0.02

    [mpc]
    horizon = 10
    iterations = 2
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

mpc_macros::mpc!(mod second {
    r#"
    [model]
    type = "double_integrator"
    axes = 1
    dt = 0.05

    [mpc]
    horizon = 10
    iterations = 2
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
    assert_eq!(first::ITERATIONS, 2);
    assert_eq!(second::ITERATIONS, 2);
    let mut a = first::Controller::new([0.0; first::NX]);
    let mut b = second::Controller::new([0.0; second::NX]);
    let xref = [[1.0, 0.0]; first::N];
    assert!(a.step(&[0.0; first::NY], &xref)[0] > 0.0);
    assert!(b.step(&[0.0; second::NY], &xref)[0] > 0.0);
}
