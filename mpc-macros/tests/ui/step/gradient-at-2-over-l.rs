// A fixed step above 2/L for `gradient` (L = 0.48007 here, 2/L = 4.16606).
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "double_integrator"
    axes = 1
    dt = 0.1

    [mpc]
    horizon = 10
    iterations = 20
    method = "gradient"
    step = 4.17
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
