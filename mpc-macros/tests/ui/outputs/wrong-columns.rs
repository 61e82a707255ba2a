// `outputs` must map the state: nx columns.
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
    outputs = [[1, 0, 0]]
    q = 1
    r = 0.1
    u_min = [-1]
    u_max = [1]
    "#
});

fn main() {}
