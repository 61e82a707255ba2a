// Move blocks past the prediction horizon: an error (MATLAB truncates them), the hint names the truncation.
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "double_integrator"
    axes = 1
    dt = 0.1

    [mpc]
    horizon = 10
    move_blocking = [4, 4, 4]
    iterations = 20
    q = [1, 0.1]
    r = [0.1]
    u_min = [-1]
    u_max = [1]

    [kalman]
    sigma_a = 0.5
    sigma_meas = 0.2
    "#
});

fn main() {}
