// Under the default, `method = "auto"`, a state bound is taken by the interior-point method, which is
// certified on a sampled region: without `[mpc.region]` and with a state unbounded on one side, there is none.
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
    q = 1
    r = 0.1
    u_min = [-1]
    u_max = [1]
    x_min = [-5, -2]
    "#
});

fn main() {}
