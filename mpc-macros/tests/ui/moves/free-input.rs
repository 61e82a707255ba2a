// r = 0 and a move weight that misses an input the outputs do not see: H is singular.
mpc_macros::mpc!(mod controller {
    r#"
    [model]
    type = "linear"
    dt = 0.1
    a = [[1, 0], [0, 1]]
    b = [[0.1, 0], [0, 0.1]]

    [mpc]
    horizon = 5
    iterations = 10
    outputs = [[1, 0]]
    q = 1
    r = [0, 0]
    r_du = [1, 0]
    u_min = [-1, -1]
    u_max = [1, 1]
    "#
});

fn main() {}
