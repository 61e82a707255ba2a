// A closed loop that is not stable: plant x+ = 2x + u, a one-step horizon and R = 100 Q give u = -0.0198x, so x+ = 1.98x.
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "linear"
    a = [[2.0]]
    b = [[1.0]]
    c = [[1.0]]
    dt = 0.1

    [mpc]
    horizon = 1
    iterations = 20
    q = [1]
    r = [100]
    u_min = [-10]
    u_max = [10]

    [kalman]
    q = [[0.01]]
    r = [[0.01]]
    "#
});

fn main() {}
