// `[model] time` spelled wrong: the valid spellings are the hint.
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "linear"
    time = "contiuous"
    dt = 0.1
    a = [[0, 1], [0, 0]]
    b = [[0], [1]]
    c = [[1, 0]]

    [mpc]
    horizon = 10
    iterations = 20
    q = [1, 0.1]
    r = [0.1]
    u_min = [-1]
    u_max = [1]

    [kalman]
    q = [1e-4, 1e-3]
    r = 0.01
    "#
});

fn main() {}
