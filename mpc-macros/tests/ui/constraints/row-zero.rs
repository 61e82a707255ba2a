// A row zero in `ax` and `au` bounds a constant.
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "linear"
    dt = 0.1
    a = [[1, 0.1], [0, 1]]
    b = [[0.005], [0.1]]

    [mpc]
    horizon = 10
    iterations = 20
    method = "ipm"
    q = 1
    r = 0.1
    u_min = [-1]
    u_max = [1]

    [[mpc.constraint]]
    ax = [[1, 0], [0, 0]]
    upper = [1, 1]
    "#
});

fn main() {}
