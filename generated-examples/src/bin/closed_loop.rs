//! The generated controller of `specs/paper.toml` flying a double integrator from rest to a set point
//! 1 m, 2 m and 3 m away, with noiseless position measurements. Prints the trajectory every 0.25 s and
//! exits non-zero unless every axis settles within 1 cm.

use generated_examples::paper::{Controller, Real, DT, N, NX};

fn main() {
    let target: [Real; NX] = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0];
    let xref = [target; N];
    let mut controller = Controller::new([0.0; NX]);
    // The plant, in f64: positions then velocities per axis (paper eq. 2).
    let mut x = [0.0_f64; NX];
    let dt = f64::from(DT);
    let steps = (4.0 / dt) as usize;
    println!("   t [s]      x [m]      y [m]      z [m]    ax [m/s²]  ay [m/s²]  az [m/s²]");
    for k in 0..steps {
        let z = [x[0] as Real, x[1] as Real, x[2] as Real];
        let u = controller.step(&z, &xref);
        for axis in 0..3 {
            let a = f64::from(u[axis]);
            x[axis] += dt * x[axis + 3] + 0.5 * dt * dt * a;
            x[axis + 3] += dt * a;
        }
        if k % 20 == 0 || k + 1 == steps {
            println!(
                "{:8.3} {:10.4} {:10.4} {:10.4} {:10.3} {:10.3} {:10.3}",
                k as f64 * dt,
                x[0],
                x[1],
                x[2],
                u[0],
                u[1],
                u[2]
            );
        }
    }
    let worst = (0..3)
        .map(|i| (x[i] - f64::from(target[i])).abs())
        .fold(0.0, f64::max);
    println!(
        "largest position error after {:.1} s: {:.2e} m",
        steps as f64 * dt,
        worst
    );
    if worst > 0.01 {
        eprintln!("the closed loop did not settle");
        std::process::exit(1);
    }
}
