// `linear` matrices whose dimensions disagree: `c` has 3 columns for nx = 2.
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "linear"
    a = [[1.0, 0.1], [0.0, 1.0]]
    b = [[0.0], [0.1]]
    c = [[1.0, 0.0, 0.0]]
    dt = 0.1

    [mpc]
    horizon = 1
    iterations = 20
    q = [1, 1]
    r = [100]
    u_min = [-10]
    u_max = [10]

    [kalman]
    q = [[0.01, 0], [0, 0.01]]
    r = [[0.01]]
    "#
});

fn main() {}
