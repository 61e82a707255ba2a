//! Offset-free MPC (`[kalman] disturbance`): generated against the generic solver, and in closed loop
//! under a constant input disturbance.
#![allow(non_snake_case)]

use codegen::oracle;
use mpc_tests::generated::*;
use mpc_tests::harness::*;
use nalgebra::DVector;
use rand::Rng;
use rand_distr::StandardNormal;

/// The same tolerance form as `generated_vs_generic.rs`, with the disturbance's term ‖Fd‖∞·|d|∞ added.
const K_MPC: f64 = 4.0;

fn compare_offset_free_mpc<G: OffsetFree>(seed: u64) -> f64 {
    let p = G::problem();
    let qp = &p.qp;
    let (nx, nu, N) = (p.nx, p.nu, qp.N);
    let mut rng = rng(seed);
    let mut oracle = oracle::Mpc::new(&p);
    let mut generated = G::mpc_new();
    let u_abs = qp.u_min.amax().max(qp.u_max.amax());
    let round = |v: &DVector<f64>| v.map(G::round);
    let mut worst: f64 = 0.0;
    for run in 0..100 {
        let scale = [0.01, 0.3, 3.0, 30.0][run % 4];
        oracle.reset();
        G::mpc_reset(&mut generated);
        let center = random_vector(&mut rng, nx, scale);
        for _ in 0..10 {
            let x0 = round(&random_vector(&mut rng, nx, scale));
            let d = round(&random_vector(&mut rng, nu, 0.2 * u_abs));
            let xref: Vec<DVector<f64>> = (0..N)
                .map(|_| round(&(&center + random_vector(&mut rng, nx, 0.1 * scale))))
                .collect();
            let xref_vec: Vec<Vec<f64>> =
                xref.iter().map(|r| r.iter().copied().collect()).collect();
            oracle.solve_with_disturbance(&x0, &d, &xref);
            let u = G::mpc_solve_with_disturbance(
                &mut generated,
                x0.as_slice(),
                d.as_slice(),
                &xref_vec,
            );
            assert!(u
                .iter()
                .enumerate()
                .all(|(j, v)| v.is_finite() && *v >= qp.u_min[j] && *v <= qp.u_max[j]));
            let r_abs = xref.iter().map(|r| r.amax()).fold(0.0, f64::max);
            let scale = mpc_error_scale(qp, G::epsilon(), x0.amax(), r_abs, d.amax());
            let diff = max_difference(&G::mpc_plan(&generated), oracle.plan().iter());
            worst = worst.max(diff / scale);
        }
    }
    println!("{}: worst error {worst:.3} × ε·scale/μ", G::SPEC);
    worst
}

#[test]
fn offset_free_mpc_matches_the_generic_solver() {
    for worst in [
        compare_offset_free_mpc::<offset_free>(1),
        compare_offset_free_mpc::<offset_free_f64>(2),
        compare_offset_free_mpc::<linear_offset_free>(3),
        // Every emission choice: auto chose lanes (paper) and a table (linear), the key forced the rest.
        compare_offset_free_mpc::<offset_free_unrolled>(7),
        compare_offset_free_mpc::<offset_free_table>(8),
        compare_offset_free_mpc::<offset_free_matrix_free>(9),
        compare_offset_free_mpc::<linear_offset_free_unrolled>(10),
        compare_offset_free_mpc::<linear_offset_free_matrix_free>(11),
    ] {
        assert!(
            worst <= K_MPC,
            "error {worst} × the scale exceeds k = {K_MPC}"
        );
    }
}

/// The augmented filter's state and disturbance estimates against the generic filter on a plant pushed
/// by a constant input disturbance (tolerance as in `kalman_vs_generic.rs`).
fn compare_offset_free_filter<G: OffsetFree>(seed: u64) -> f64 {
    let p = G::problem();
    let (nx, nu, ny, nd) = (p.nx, p.nu, p.ny, p.nd());
    let na = nx + nd;
    let f = p.filter.as_ref().expect("a filter");
    let rho = codegen::linalg::spectral_radius(
        &(&f.Fa * (nalgebra::DMatrix::identity(na, na) - &f.K_inf * &f.Ca)),
    );
    let mut rng = rng(seed);
    let disturbance = random_vector(&mut rng, nu, 1.0);
    let mut x = DVector::zeros(nx);
    let mut oracle = oracle::Kalman::new(&p, DVector::zeros(nx)).expect("the spec has a filter");
    let mut generated = G::kalman_new(&vec![0.0; nx]);
    let (mut scale, mut worst) = (0.0_f64, 0.0_f64);
    let mut d_sum = vec![0.0; nu];
    for step in 0..2000 {
        let noise = DVector::from_fn(ny, |i, _| {
            f.Rn[(i, i)].sqrt() * rng.sample::<f64, _>(StandardNormal)
        });
        let z = (&p.C * &x + noise).map(G::round);
        oracle.update(&z);
        G::kalman_update(&mut generated, z.as_slice());
        let u =
            DVector::from_fn(nu, |j, _| rng.gen_range(p.qp.u_min[j]..=p.qp.u_max[j])).map(G::round);
        oracle.predict(&u);
        G::kalman_predict(&mut generated, u.as_slice());
        x = &p.F * &x + &p.G * (&u + &disturbance);
        let estimate: Vec<f64> = G::kalman_state(&generated)
            .into_iter()
            .chain(G::kalman_disturbance(&generated))
            .collect();
        scale = scale.max(oracle.state().amax() + z.amax());
        let diff = estimate
            .iter()
            .zip(oracle.state().iter())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f64::max);
        worst = worst.max(diff / (G::epsilon() * scale / (1.0 - rho)));
        if step >= 1000 {
            for (s, d) in d_sum.iter_mut().zip(G::kalman_disturbance(&generated)) {
                *s += d / 1000.0;
            }
        }
    }
    // The estimate found the disturbance (averaged over the last 1000 cycles: it is a noisy random walk).
    let d_hat = d_sum;
    for j in 0..nu {
        assert!(
            (d_hat[j] - disturbance[j]).abs() < 0.1 * (1.0 + disturbance[j].abs()),
            "d̂ {d_hat:?} vs {:?}",
            disturbance.as_slice()
        );
    }
    println!(
        "{}: worst filter error {worst:.3} × ε·scale/(1 − ρ)",
        G::SPEC
    );
    worst
}

#[test]
fn offset_free_filter_matches_the_generic_filter() {
    for worst in [
        compare_offset_free_filter::<offset_free>(4),
        compare_offset_free_filter::<offset_free_f64>(5),
        compare_offset_free_filter::<linear_offset_free>(6),
    ] {
        assert!(worst <= 4.0, "error {worst} × the scale exceeds k = 4");
    }
}

/// Hovers at the origin for `seconds` with the simulation's default noise (GPS 0.3 m, acceleration
/// 0.5 m/s²) and a constant `push` on the acceleration; returns (position errors, disturbance estimates).
fn hover<C>(
    seed: u64,
    seconds: f64,
    push: [f64; 3],
    mut controller: C,
) -> (Vec<[f64; 3]>, Vec<[f64; 3]>)
where
    C: FnMut(&[f32; 3]) -> ([f32; 3], [f64; 3]),
{
    let dt = 0.0128;
    let mut rng = rng(seed);
    let (mut p, mut v) = ([0.0_f64; 3], [0.0_f64; 3]);
    let (mut errors, mut estimates) = (Vec::new(), Vec::new());
    for _ in 0..(seconds / dt) as usize {
        let z: [f32; 3] =
            core::array::from_fn(|i| (p[i] + 0.3 * rng.sample::<f64, _>(StandardNormal)) as f32);
        let (u, d_hat) = controller(&z);
        for i in 0..3 {
            let a = u[i] as f64 + push[i] + 0.5 * rng.sample::<f64, _>(StandardNormal);
            p[i] += dt * v[i] + 0.5 * dt * dt * a;
            v[i] += dt * a;
        }
        errors.push(p);
        estimates.push(d_hat);
    }
    (errors, estimates)
}

fn mean_over_last(values: &[[f64; 3]], n: usize, axis: usize) -> f64 {
    values[values.len() - n..]
        .iter()
        .map(|v| v[axis])
        .sum::<f64>()
        / n as f64
}

#[test]
fn constant_disturbance_leaves_no_offset() {
    let xref = [[0.0_f32; 6]; 15];
    let push = [0.0, 0.6, -0.3];
    let last = (10.0 / 0.0128) as usize;
    for seed in 1..=4 {
        let mut plain = mpc_tests::paper::Controller::new([0.0; 6]);
        let (plain_errors, _) = hover(seed, 40.0, push, |z| (plain.step(z, &xref), [0.0; 3]));
        let mut free = mpc_tests::offset_free::Controller::new([0.0; 6]);
        let (free_errors, estimates) = hover(seed, 40.0, push, |z| {
            let u = free.step(z, &xref);
            (
                u,
                core::array::from_fn(|i| free.kalman().disturbance()[i] as f64),
            )
        });
        for axis in [1, 2] {
            let held = mean_over_last(&plain_errors, last, axis);
            let offset = mean_over_last(&free_errors, last, axis);
            let d_hat = mean_over_last(&estimates, last, axis);
            assert!(
                held.abs() > 0.3,
                "seed {seed}, axis {axis}: the plain MPC holds only {held} m"
            );
            assert!(
                offset.abs() < 0.03,
                "seed {seed}, axis {axis}: offset-free MPC holds {offset} m"
            );
            assert!(
                (d_hat - push[axis]).abs() < 0.05,
                "seed {seed}, axis {axis}: d̂ = {d_hat}, push {}",
                push[axis]
            );
        }
    }
}

#[test]
fn without_disturbance_the_offset_free_controller_flies_like_the_plain_one() {
    let xref = [[0.0_f32; 6]; 15];
    // The budget: at most 1.1 times the plain MPC's RMS error, averaged over seeds.
    let (mut plain_ms, mut free_ms) = ([0.0; 3], [0.0; 3]);
    for seed in 1..=6 {
        let mut plain = mpc_tests::paper::Controller::new([0.0; 6]);
        let (plain_errors, _) = hover(seed, 30.0, [0.0; 3], |z| (plain.step(z, &xref), [0.0; 3]));
        let mut free = mpc_tests::offset_free::Controller::new([0.0; 6]);
        let (free_errors, _) = hover(seed, 30.0, [0.0; 3], |z| (free.step(z, &xref), [0.0; 3]));
        for axis in 0..3 {
            let ms =
                |e: &[[f64; 3]]| e.iter().map(|v| v[axis] * v[axis]).sum::<f64>() / e.len() as f64;
            plain_ms[axis] += ms(&plain_errors) / 6.0;
            free_ms[axis] += ms(&free_errors) / 6.0;
        }
    }
    for axis in 0..3 {
        let (a, b) = (plain_ms[axis].sqrt(), free_ms[axis].sqrt());
        println!("axis {axis}: plain {a:.4} m, offset-free {b:.4} m RMS");
        assert!(
            b <= 1.1 * a,
            "axis {axis}: offset-free RMS {b} vs plain {a}"
        );
    }
}
