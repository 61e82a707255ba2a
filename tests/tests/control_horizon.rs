//! `[mpc] control_horizon` (Nc < N): the inputs u_0 … u_{Nc−1} are free, u_k = u_{Nc−1} after; and
//! `[mpc] move_blocking` (MATLAB's vector `ControlHorizon`): one free input per block of steps.
//! - The lowered QP is the full-horizon QP with U = T·V substituted, T formed here from the definition
//!   (H = TᵀHT, the linear maps Tᵀ·, Su·T, the rows' coefficients on U times T, their data unchanged), on
//!   specs with every kind of row, weighted moves, `qf = "lqr"`, outputs and a disturbance model.
//! - The oracle's plan is the optimum of the full-horizon QP with the held steps as equality rows
//!   u_k − u_s = 0 (s the first step of k's block), solved by Clarabel (independent of the substitution).
//! - Generated controllers (active set, interior point, FGM with f from the tables and unrolled) against
//!   the oracle on warm-started closed loops: the same plan, N steps from `plan()`, each block's steps
//!   equal.
#![allow(non_snake_case)]

use codegen::ipm::InequalityQp;
use codegen::oracle;
use mpc_tests::harness::*;
use nalgebra::{DMatrix, DVector};

#[allow(dead_code)]
#[path = "../benches/exact.rs"]
mod exact;

mpc_macros::mpc!(mod pendulum = "../specs/pendulum.toml");
mpc_macros::mpc!(mod linear_active_set = "specs/control-horizon/linear-active-set.toml");
mpc_macros::mpc!(mod linear_ipm = "specs/control-horizon/linear-ipm.toml");
mpc_macros::mpc!(mod pendulum_fgm = "specs/control-horizon/pendulum-fgm.toml");
mpc_macros::mpc!(mod offset_free = "specs/control-horizon/offset-free-unrolled.toml");
mpc_macros::mpc!(mod blocks_active_set = "specs/control-horizon/blocks-active-set.toml");
mpc_macros::mpc!(mod blocks_ipm = "specs/control-horizon/blocks-ipm.toml");
mpc_macros::mpc!(mod blocks_fgm = "specs/control-horizon/blocks-fgm.toml");

const PENDULUM: &str = include_str!("../../specs/pendulum.toml");
const LINEAR_ACTIVE_SET: &str = include_str!("../specs/control-horizon/linear-active-set.toml");
const LINEAR_IPM: &str = include_str!("../specs/control-horizon/linear-ipm.toml");
const PENDULUM_FGM: &str = include_str!("../specs/control-horizon/pendulum-fgm.toml");
const OFFSET_FREE: &str = include_str!("../specs/control-horizon/offset-free-unrolled.toml");
const BLOCKS_ACTIVE_SET: &str = include_str!("../specs/control-horizon/blocks-active-set.toml");
const BLOCKS_IPM: &str = include_str!("../specs/control-horizon/blocks-ipm.toml");
const BLOCKS_FGM: &str = include_str!("../specs/control-horizon/blocks-fgm.toml");

/// The spec without its `control_horizon` or `move_blocking` line: the full-horizon problem.
fn full(text: &str) -> String {
    text.lines()
        .filter(|l| {
            let l = l.trim_start();
            !l.starts_with("control_horizon") && !l.starts_with("move_blocking")
        })
        .map(|l| format!("{l}\n"))
        .collect()
}

/// The first step of each step's block, from the spec's text as docs/spec.md defines it: `control_horizon
/// = Nc` holds steps Nc … N−1 at step Nc − 1; `move_blocking = [b₀, b₁, …]` makes blocks of those lengths,
/// a sum short of N getting a last block of the rest.
fn block_starts(text: &str, N: usize) -> Vec<usize> {
    let value = |key: &str| {
        text.lines()
            .find_map(|l| l.trim_start().strip_prefix(key))
            .map(|rest| rest.trim_start().trim_start_matches('=').trim().to_string())
    };
    let mut lengths: Vec<usize> = if let Some(nc) = value("control_horizon") {
        let nc: usize = nc.parse().unwrap();
        (0..nc - 1).map(|_| 1).chain([N + 1 - nc]).collect()
    } else {
        let list = value("move_blocking").expect("a control horizon or move blocking");
        list.trim_matches(['[', ']'])
            .split(',')
            .map(|b| b.trim().parse().unwrap())
            .collect()
    };
    let sum: usize = lengths.iter().sum();
    if sum < N {
        lengths.push(N - sum);
    }
    let mut starts = Vec::new();
    for b in lengths {
        let s = starts.len();
        starts.extend(std::iter::repeat_n(s, b));
    }
    assert_eq!(starts.len(), N, "the blocks cover the horizon");
    starts
}

/// The blocking matrix by its definition: row block k of U is the column block of V that k's block
/// holds (blocks numbered in order of their first steps).
fn blocking(starts: &[usize], nu: usize) -> DMatrix<f64> {
    let mut firsts: Vec<usize> = starts.to_vec();
    firsts.dedup();
    let mut T = DMatrix::zeros(starts.len() * nu, firsts.len() * nu);
    for (k, s) in starts.iter().enumerate() {
        let j = firsts.iter().position(|f| f == s).unwrap();
        for i in 0..nu {
            T[(k * nu + i, j * nu + i)] = 1.0;
        }
    }
    T
}

fn uncertified(text: &str) -> codegen::Problem {
    codegen::lower::uncertified(&mpc_spec::load(text).expect("valid spec")).expect("lowerable")
}

fn assert_close(what: &str, a: &DMatrix<f64>, b: &DMatrix<f64>) {
    assert_eq!(a.shape(), b.shape(), "{what}: shapes");
    let scale = b.amax().max(1.0);
    let d = (a - b).amax();
    assert!(
        d <= 1e-10 * scale,
        "{what}: differs by {d:e} (scale {scale:e})"
    );
}

#[test]
fn lowered_qp_is_the_full_qp_substituted() {
    for (name, text) in [
        ("linear", LINEAR_ACTIVE_SET),
        ("pendulum", PENDULUM),
        ("offset-free", OFFSET_FREE),
        ("linear, move blocking", BLOCKS_ACTIVE_SET),
        ("pendulum, move blocking", BLOCKS_FGM),
    ] {
        let (b, f) = (uncertified(text), uncertified(&full(text)));
        let (qb, qf) = (&b.qp, &f.qp);
        assert!(qb.Nc < qb.N && qf.Nc == qf.N, "{name}: a control horizon");
        let T = blocking(&block_starts(text, qf.N), f.nu);
        assert_eq!(T.ncols(), qb.Nc * f.nu, "{name}: the free inputs");
        let Tt = T.transpose();
        assert_close(&format!("{name} H"), &qb.H, &(&Tt * &qf.H * &T));
        assert_close(&format!("{name} Fx"), &qb.Fx, &(&Tt * &qf.Fx));
        assert_close(&format!("{name} Fr"), &qb.Fr, &(&Tt * &qf.Fr));
        assert_close(&format!("{name} Fu"), &qb.Fu, &(&Tt * &qf.Fu));
        assert_close(&format!("{name} Fd"), &qb.Fd, &(&Tt * &qf.Fd));
        assert_close(&format!("{name} Su"), &qb.Su, &(&qf.Su * &T));
        let n = qf.N * f.nu;
        let ns = qf.rows.slacks();
        let (Ab, Af) = (&qb.rows.A, &qf.rows.A);
        assert_close(
            &format!("{name} rows on the plan"),
            &Ab.columns(0, qb.Nc * f.nu).into_owned(),
            &(Af.columns(0, n) * &T),
        );
        assert_close(
            &format!("{name} rows on the slacks"),
            &Ab.columns(qb.Nc * f.nu, ns).into_owned(),
            &Af.columns(n, ns).into_owned(),
        );
        assert_eq!(qb.rows.lower, qf.rows.lower, "{name}: lower");
        assert_eq!(qb.rows.upper, qf.rows.upper, "{name}: upper");
        assert_close(&format!("{name} Wx"), &qb.rows.Wx, &qf.rows.Wx);
        assert_close(&format!("{name} Wu"), &qb.rows.Wu, &qf.rows.Wu);
        assert_close(&format!("{name} Wd"), &qb.rows.Wd, &qf.rows.Wd);
    }
}

/// The full-horizon QP of `full_p` at `c` with the held steps as equality rows u_k − u_s = 0, s =
/// `starts[k]` the first step of k's block.
fn held_by_rows(full_p: &codegen::Problem, starts: &[usize], c: &Drawn) -> InequalityQp {
    let reference = oracle::Mpc::new(full_p);
    let (mut qp, _) = qp_of(full_p, &reference, c);
    let nu = full_p.nu;
    let held: Vec<(usize, usize)> = starts
        .iter()
        .enumerate()
        .filter(|(k, s)| *k != **s)
        .map(|(k, s)| (k, *s))
        .collect();
    let extra = held.len() * nu;
    let (m, nz) = qp.A.shape();
    let mut A = DMatrix::zeros(m + extra, nz);
    A.rows_mut(0, m).copy_from(&qp.A);
    for (h, (k, s)) in held.iter().enumerate() {
        for i in 0..nu {
            let r = m + h * nu + i;
            A[(r, k * nu + i)] = 1.0;
            A[(r, s * nu + i)] = -1.0;
        }
    }
    qp.A = A;
    qp.lower = qp.lower.clone().insert_rows(m, extra, 0.0);
    qp.upper = qp.upper.clone().insert_rows(m, extra, 0.0);
    qp
}

#[test]
fn oracle_plan_is_the_held_optimum() {
    for (name, text, seed) in [
        ("pendulum", PENDULUM, 1),
        ("linear", LINEAR_IPM, 2),
        ("linear, move blocking", BLOCKS_IPM, 3),
    ] {
        let p = problem(text);
        let full_p = uncertified(&full(text));
        let mut rng = rng(seed);
        let mut worst: f64 = 0.0;
        for _ in 0..10 {
            let c = draw(&p, &mut rng, 1.0);
            let mut mpc = oracle::Mpc::new(&p);
            mpc.solve(&c.x0, &window(&p, &c.reference));
            let qp = held_by_rows(&full_p, &block_starts(text, p.qp.N), &c);
            if codegen::ipm::solve(&qp, 1e-10, 200).status != codegen::ipm::Status::Converged {
                continue;
            }
            let exact = exact::clarabel(&qp);
            let plan = mpc.plan();
            assert_eq!(plan.len(), p.qp.N * p.nu, "{name}: plan() has N steps");
            for i in 0..plan.len() {
                worst = worst.max((plan[i] - exact[i]).abs() / span(&p, i));
            }
        }
        println!("{name}: worst |U − U*|∞ / span {worst:e}");
        assert!(
            worst <= p.qp.accuracy,
            "{name}: {worst:e} of the span from the held optimum"
        );
    }
}

/// A generated module beside the oracle over warm-started sequences: the worst plan difference over the
/// span, after checking that `plan()` holds each block's input over its steps.
macro_rules! run {
    ($m:ident, $text:expr, $seed:expr, $sequences:expr, $steps:expr, $draw:expr) => {{
        use $m as m;
        let p = problem($text);
        let mut rng = rng($seed);
        let mut worst: f64 = 0.0;
        for _ in 0..$sequences {
            let mut generated = m::Mpc::new();
            let mut reference = oracle::Mpc::new(&p);
            let (mut x0, r): (DVector<f64>, DVector<f64>) = $draw(&p, &mut rng);
            for _ in 0..$steps {
                let window = window(&p, &r);
                let u = reference.solve(&x0, &window);
                let x: [m::Real; m::NX] = std::array::from_fn(|i| x0[i] as m::Real);
                let row = std::array::from_fn(|i| r[i] as m::Real);
                let v = generated.solve(&x, &[row; m::N]);
                for (j, v) in v.iter().enumerate() {
                    assert!(v.is_finite() && *v >= m::U_MIN[j] && *v <= m::U_MAX[j]);
                }
                let plan = generated.plan();
                assert_eq!(m::CONTROL_HORIZON, p.qp.Nc);
                assert_eq!(m::MOVE_BLOCKS.iter().sum::<usize>(), m::N);
                for (k, s) in block_starts($text, m::N).into_iter().enumerate() {
                    assert_eq!(plan[k], plan[s], "step {k} is held at step {s}");
                }
                let flat: Vec<f64> = plan.iter().flatten().map(|v| *v as f64).collect();
                for (i, (a, b)) in flat.iter().zip(reference.plan().iter()).enumerate() {
                    worst = worst.max((a - b).abs() / span(&p, i));
                }
                x0 = &p.F * &x0 + &p.G * &u;
            }
        }
        worst
    }};
}

/// A state and reference in the certificate's region.
fn in_region(
    p: &codegen::Problem,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> (DVector<f64>, DVector<f64>) {
    let c = draw(p, rng, 1.0);
    (c.x0, c.reference)
}

/// A state near rest and a reference of the tracked outputs (state components without outputs).
fn near_rest(
    p: &codegen::Problem,
    rng: &mut rand_chacha::ChaCha8Rng,
) -> (DVector<f64>, DVector<f64>) {
    (
        random_vector(rng, p.nx, 0.2),
        random_vector(rng, p.qp.nz, 1.0),
    )
}

#[test]
fn generated_matches_the_oracle() {
    let cases = [
        (
            "pendulum (active set)",
            run!(pendulum, PENDULUM, 1, 3, 30, in_region),
        ),
        (
            "linear (active set)",
            run!(linear_active_set, LINEAR_ACTIVE_SET, 2, 3, 20, in_region),
        ),
        (
            "linear (ipm)",
            run!(linear_ipm, LINEAR_IPM, 3, 3, 20, in_region),
        ),
        (
            "pendulum (fgm, table)",
            run!(pendulum_fgm, PENDULUM_FGM, 4, 3, 30, near_rest),
        ),
        (
            "offset-free (fgm, unrolled)",
            run!(offset_free, OFFSET_FREE, 5, 3, 30, near_rest),
        ),
        (
            "linear, move blocking (active set)",
            run!(blocks_active_set, BLOCKS_ACTIVE_SET, 6, 3, 20, in_region),
        ),
        (
            "linear, move blocking (ipm)",
            run!(blocks_ipm, BLOCKS_IPM, 7, 3, 20, in_region),
        ),
        (
            "pendulum, move blocking (fgm, table)",
            run!(blocks_fgm, BLOCKS_FGM, 8, 3, 30, near_rest),
        ),
    ];
    for (name, worst) in cases {
        println!("{name}: worst |U_generated − U_oracle|∞ / span {worst:e}");
        assert!(
            worst <= 1e-9,
            "{name}: {worst:e} of the span from the oracle"
        );
    }
}

flight_sim::linear_mpc_controller!(struct Pendulum(pendulum), filter, NZ);

/// The published pendulum's flights on `flight_sim::fly_linear`, the plant sampled by the compiler: per
/// seed 1-5 and noise (the spec's process and measurement noise, then its measurement noise alone), from
/// rest, the cart's position p stepped to 1 m at t = 0, 10 s. Each flight's (seed, with the process
/// noise, max true |θ|, max |u|, max |p − 1| from 5 s on), printed as it goes.
fn fly_pendulum(spec: &mpc_spec::Spec) -> Vec<(u64, bool, f64, f64, f64)> {
    use codegen::linalg::array;
    use flight_sim::{fly_linear, lower_factor, LinearNoiseConfig, LinearPlant, LinearScenario};
    let p = codegen::lower(spec).unwrap();
    let filter = p.filter.as_ref().expect("the spec has a filter");
    assert_eq!((pendulum::NX, pendulum::NU, pendulum::NY), (4, 1, 2));
    let measurement_sigma = core::array::from_fn(|i| filter.Rn[(i, i)].sqrt());
    let process = Some(lower_factor(&array(&filter.Qn)).expect("a covariance"));
    let mut flights = Vec::new();
    for seed in 1..=5 {
        for process_factor in [process, None] {
            let mut plant =
                LinearPlant::<4, 1, 2>::new(array(&p.F), array(&p.G), array(&p.C), [0.0; 4]);
            let scenario = LinearScenario {
                seed,
                cycles: (10.0 / p.dt).round() as usize,
                dt: p.dt,
                noise: LinearNoiseConfig {
                    process_factor,
                    measurement_sigma,
                },
            };
            let mut controller = Pendulum::new(&[0.0; 4]);
            let (mut theta, mut u, mut late) = (0.0_f64, 0.0_f64, 0.0_f64);
            fly_linear(
                &mut plant,
                &mut controller,
                &|_t: f64| [1.0, 0.0],
                &pendulum::CZ,
                &scenario,
                |_| [0.0; 1],
                |s, _| {
                    theta = theta.max(s.state[2].abs());
                    u = u.max(s.command[0].abs());
                    if s.t >= 5.0 {
                        late = late.max((s.state[0] - 1.0).abs());
                    }
                },
            );
            let noise = if process_factor.is_some() {
                "the spec's noise"
            } else {
                "measurement noise alone"
            };
            eprintln!(
                "pendulum, seed {seed}, {noise}: max |θ| {theta:.5} rad, max |u| {u:.4}, |p − 1| after 5 s {late:.5} m"
            );
            flights.push((seed, process_factor.is_some(), theta, u, late));
        }
    }
    flights
}

/// Issue 34's flight of the published pendulum (`specs/pendulum.toml`: N = 10, Nc = 5, `qf = "lqr"`,
/// the θ bound backed off by 3σ of the filter's error), [`fly_pendulum`]'s ten flights:
/// - With the spec's own process and measurement noise: the true |θ| within its 0.2 rad bound and |u|
///   within 2 throughout (without the back-off the true |θ| reaches 0.2030 on seed 1).
/// - With its measurement noise alone: also p within 2 % of 1 m from 5 s on.
/// - Under the spec's process noise p stays several centimetres off, more than 2 %: no controller can do
///   better ([`no_controller_holds_p_within_2_percent_under_the_process_noise`]).
#[test]
fn the_published_pendulum_steps_a_metre_within_its_bounds() {
    let spec = mpc_spec::load(PENDULUM).unwrap();
    let flights = fly_pendulum(&spec);
    let theta_max = spec.mpc.constraints.x_max[2];
    let u_max = spec.mpc.u_max[0];
    for &(seed, process, theta, u, late) in &flights {
        assert!(
            theta <= theta_max,
            "seed {seed}, process noise {process}: the true |θ| reached {theta} rad"
        );
        assert!(
            u <= u_max,
            "seed {seed}, process noise {process}: |u| reached {u}"
        );
        if process {
            assert!(late > 0.02, "seed {seed}: p off 1 m by only {late} after 5 s: the bound below says it cannot be");
        } else {
            assert!(late <= 0.02, "seed {seed}: p off 1 m by {late} after 5 s");
        }
    }
}

/// Why p is not held within 2 % (2 cm) of its reference under the spec's process noise, whatever the
/// controller: a lower bound on the steady-state mean square of p's error over every causal policy with
/// |u| ≤ 2, even one that knows the true state.
///
/// For any R > 0 the LQR with stage cost p² + R·u² is optimal among all causal policies for the average
/// cost E[p²] + R·E[u²] under Gaussian process noise (LQG theory), with optimal value J*_R. A policy with
/// |u| ≤ u_max has R·E[u²] ≤ R·u_max², so its E[p²] ≥ J*_R − R·u_max². Here J*_R is computed from the
/// plant the flight flies (the compiler's F, G and the filter's Qn: Van Loan's sampling of the spec's
/// `q`), by the Riccati recursion iterated to convergence and the closed loop's stationary covariance X
/// (X = A_cl·X·A_clᵀ + Qn iterated): J*_R = X_pp + R·K·X·Kᵀ. The bound, about 1.93 cm, comes from the
/// plant, not a tuning: the cart must accelerate to keep the unstable pendulum up (θ̈ = 19.62·θ + 2·p̈
/// once u is eliminated), and noise on both speeds makes it. A root mean square of at least 1.93 cm
/// cannot stay within 2 cm over 500 samples; the flights above are 6.4-7.5 cm off at worst.
#[test]
fn no_controller_holds_p_within_2_percent_under_the_process_noise() {
    let spec = mpc_spec::load(PENDULUM).unwrap();
    let p = codegen::lower(&spec).unwrap();
    let filter = p.filter.as_ref().expect("the spec has a filter");
    let (F, G, Qn) = (&p.F, &p.G, &filter.Qn);
    let u_max = spec.mpc.u_max[0];
    let mut best = 0.0_f64;
    for R in [1e-4, 1e-6, 1e-8] {
        let mut Q = DMatrix::<f64>::zeros(4, 4);
        Q[(0, 0)] = 1.0;
        // The Riccati recursion S ← Q + FᵀSF − FᵀSG(R + GᵀSG)⁻¹GᵀSF from S = Q.
        let mut S = Q.clone();
        let mut K = DMatrix::<f64>::zeros(1, 4);
        for _ in 0..200_000 {
            let gain = (G.transpose() * &S * G).add_scalar(R);
            K = (G.transpose() * &S * F) / gain[(0, 0)];
            let next = &Q + F.transpose() * &S * (F - G * &K);
            let change = (&next - &S).abs().max() / next.abs().max();
            S = next;
            if change < 1e-14 {
                break;
            }
        }
        let closed = F - G * &K;
        let mut X = Qn.clone();
        for _ in 0..200_000 {
            let next = &closed * &X * closed.transpose() + Qn;
            let change = (&next - &X).abs().max() / next.abs().max();
            X = next;
            if change < 1e-14 {
                break;
            }
        }
        let optimum = X[(0, 0)] + R * (&K * &X * K.transpose())[(0, 0)];
        let floor = (optimum - R * u_max * u_max).max(0.0).sqrt();
        eprintln!("R = {R:e}: J*_R = {optimum:e}, so every controller with |u| ≤ {u_max} has RMS(p − r) ≥ {floor:.5} m");
        best = best.max(floor);
    }
    assert!(best > 0.019, "the bound is {best} m");
}

/// The boards' variants of the pendulum (tests/specs/pendulum/) are `specs/pendulum.toml` with another
/// `[codegen]`: the spec up to that table is the same text.
#[test]
fn the_boards_pendulums_are_the_shipped_one() {
    let body = |text: &str| -> String {
        let start = text.find("\n[model]\n").expect("a [model]");
        let end = text.find("\n[codegen]\n").expect("a [codegen]");
        text[start..end].to_string()
    };
    for variant in [
        include_str!("../specs/pendulum/cortex-a9.toml"),
        include_str!("../specs/pendulum/cortex-m4f.toml"),
    ] {
        assert_eq!(body(variant), body(PENDULUM));
    }
}
