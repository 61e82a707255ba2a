// The macro used from a `#![no_std]` crate: the generated module must compile against `core` alone
// (no `std` prelude, no `alloc`). trybuild builds pass cases as binaries, so `std` is linked only
// to provide the binary's runtime, at the crate root, after the generated modules.
// (trybuild builds in its own folder under the target directory, so a spec path relative to this
// file would depend on where that is: the path form is covered by the `#![no_std]` library
// `generated-examples`, this case uses the inline form.)
#![no_std]

mpc_macros::mpc!(pub mod drone {
    r#"
    [model]
    type = "double_integrator"
    axes = 3
    dt = 0.0128

    [mpc]
    horizon = 15
    iterations = 30
    q = [150, 150, 150, 5, 5, 5]
    r = [0.15, 0.15, 0.15]
    qf_scale = 50
    u_min = [-10, -10, -10]
    u_max = [10, 10, 10]

    [kalman]
    sigma_a = 0.15
    sigma_meas = [0.3, 0.3, 0.3]
    "#
});

mpc_macros::mpc!(mod inline_spec {
    r#"
    [model]
    type = "double_integrator"
    axes = 1
    dt = 0.1

    [mpc]
    horizon = 3
    iterations = 10
    q = [1, 0.1]
    r = [0.1]
    u_min = [-1]
    u_max = [1]

    [kalman]
    sigma_a = 0.5
    sigma_meas = 0.2
    filter = "steady_state"

    [codegen]
    scalar = "f64"
    "#
});

static mut CONTROLLER: drone::Controller = drone::Controller::new([0.0; drone::NX]);

extern crate std;

fn main() {
    let xref = [[1.0, 0.0, 0.0, 0.0, 0.0, 0.0]; drone::N];
    // A `static` controller, as firmware keeps it: `const fn new` makes this possible.
    let controller = unsafe { &mut *core::ptr::addr_of_mut!(CONTROLLER) };
    let u = controller.step(&[0.0; drone::NY], &xref);
    assert!(u[0] > 0.0 && u[0] <= drone::U_MAX[0]);
    let mut mpc = inline_spec::Mpc::new();
    let u = mpc.solve(&[1.0, 0.0], &[[0.0, 0.0]; inline_spec::N]);
    assert!(u[0] < 0.0);
}
