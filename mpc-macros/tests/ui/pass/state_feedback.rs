// No `[kalman]` and no `c`: state feedback, output tracking of the position, move suppression with
// r = 0. The controller takes the measured state and reports a NaN one.
mpc_macros::mpc!(pub mod controller {
    r#"
    [model]
    type = "linear"
    dt = 0.1
    a = [[1, 0.1], [0, 1]]
    b = [[0.005], [0.1]]

    [mpc]
    horizon = 10
    iterations = "auto"
    tolerance = 1e-4
    outputs = [[1, 0]]
    q = 1
    r = 0
    r_du = 0.1
    u_min = [-1]
    u_max = [1]

    [codegen]
    scalar = "f64"
    "#
});

fn main() {
    let mut c = controller::Controller::new();
    let u = c.step(&[1.0, 0.0], &[[0.0; controller::NZ]; controller::N]);
    assert!(u[0] < 0.0, "pushes back towards the reference: {u:?}");
    assert_eq!(c.status().command, controller::Command::Solved);
    assert_eq!(c.mpc().last_input(), &u);
    c.step(&[f64::NAN, 0.0], &[[0.0; controller::NZ]; controller::N]);
    assert_eq!(c.status().command, controller::Command::InvalidState);
}
