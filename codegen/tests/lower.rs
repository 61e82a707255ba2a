//! The compile-time linear algebra on the paper's problem, against the paper's equations and figures.
#![allow(non_snake_case)]

use codegen::lower;
use codegen::lower::{prediction_matrices, white_acceleration_noise};
use mpc_spec::load;
use nalgebra::DMatrix;

fn paper() -> codegen::Problem {
    lower(&load(include_str!("../../specs/paper.toml")).unwrap()).unwrap()
}

#[test]
fn paper_model_is_equation_2() {
    let p = paper();
    let dt = 0.0128;
    #[rustfmt::skip]
    let F = DMatrix::from_row_slice(6, 6, &[
        1., 0., 0., dt, 0., 0.,
        0., 1., 0., 0., dt, 0.,
        0., 0., 1., 0., 0., dt,
        0., 0., 0., 1., 0., 0.,
        0., 0., 0., 0., 1., 0.,
        0., 0., 0., 0., 0., 1.,
    ]);
    assert_eq!(p.F, F);
    assert_eq!(p.G.rows(0, 3), DMatrix::identity(3, 3) * (0.5 * dt * dt));
    assert_eq!(p.G.rows(3, 3), DMatrix::identity(3, 3) * dt);
    assert_eq!(p.C.columns(0, 3), DMatrix::identity(3, 3));
    assert_eq!(p.C.columns(3, 3), DMatrix::zeros(3, 3));
}

#[test]
fn prediction_matrices_are_equations_12_and_13() {
    let p = paper();
    let N = 15;
    let (Sx, Su) = prediction_matrices(&p.F, &p.G, N);
    let mut Fk = DMatrix::identity(6, 6);
    for k in 0..N {
        Fk = &p.F * Fk;
        assert_eq!(Sx.view((6 * k, 0), (6, 6)), Fk);
        for j in 0..N {
            let block = Su.view((6 * k, 3 * j), (6, 3));
            if j > k {
                assert_eq!(block, DMatrix::zeros(6, 3));
            } else {
                let expected = p.F.pow((k - j) as u32) * &p.G;
                assert!((block - expected).amax() < 1e-15);
            }
        }
    }
}

#[test]
fn paper_hessian_has_the_papers_structure_and_conditioning() {
    let p = paper();
    let H = &p.qp.H;
    assert_eq!(H.shape(), (45, 45));
    assert_eq!(H, &H.transpose(), "H must be exactly symmetric");
    // Three identical, decoupled axis blocks: 3 · 15² = 675 nonzeros of 2025.
    let nonzeros = H.iter().filter(|v| **v != 0.0).count();
    assert_eq!(nonzeros, 675);
    for i in 0..45 {
        for j in 0..45 {
            if i % 3 != j % 3 {
                assert_eq!(H[(i, j)], 0.0);
            } else {
                assert_eq!(H[(i, j)], H[(i - i % 3, j - j % 3)]);
            }
        }
    }
    let condition = p.qp.L / p.qp.mu;
    assert!(
        (6.5..7.1).contains(&condition),
        "condition number {condition}"
    );
    assert!(
        (0.48..0.50).contains(&(1.0 / p.qp.L)),
        "1/L = {}",
        1.0 / p.qp.L
    );
    assert_eq!(p.qp.step, 1.0 / p.qp.L);
    let r = (p.qp.mu / p.qp.L).sqrt();
    assert!((p.qp.momentum - (1.0 - r) / (1.0 + r)).abs() < 1e-15);
}

#[test]
fn gradient_map_is_equation_10() {
    let p = paper();
    let (Sx, Su) = (&p.qp.Sx, &p.qp.Su);
    let x0 = nalgebra::DVector::from_vec(vec![1.0, -2.0, 0.5, 0.1, 0.2, -0.3]);
    let Xref = nalgebra::DVector::from_fn(90, |i, _| (i as f64 * 0.37).sin());
    let mut Q_blk = DMatrix::zeros(90, 90);
    for k in 0..15 {
        let w = if k == 14 { &p.qp.Qf } else { &p.qp.Q };
        Q_blk.view_mut((6 * k, 6 * k), (6, 6)).copy_from(w);
    }
    let f_paper = Su.transpose() * &Q_blk * (Sx * &x0 - &Xref) * 2.0;
    let f = &p.qp.Fx * &x0 - &p.qp.Fr * &Xref;
    assert!((f - f_paper).amax() < 1e-9);
}

#[test]
fn process_noise_is_symmetric_with_dt3_over_2() {
    let Q = white_acceleration_noise(3, 0.0128, 0.15);
    assert_eq!(Q, Q.transpose());
    let s2 = 0.15_f64 * 0.15;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-15 * b.abs();
    assert!(close(Q[(0, 3)], s2 * 0.0128_f64.powi(3) / 2.0));
    assert!(close(Q[(0, 0)], s2 * 0.0128_f64.powi(4) / 4.0));
    assert!(close(Q[(3, 3)], s2 * 0.0128_f64.powi(2)));
    assert_eq!(Q[(0, 1)], 0.0);
}

#[test]
fn steady_state_gain_solves_the_riccati_equation() {
    let p = paper();
    let f = p.filter.as_ref().expect("the spec has a filter");
    let (K, post) = codegen::linalg::kalman_gain_and_posterior(&f.P_inf, &p.C, &f.Rn).unwrap();
    assert!((&K - &f.K_inf).amax() < 1e-15);
    let next = &p.F * post * p.F.transpose() + &f.Qn;
    assert!((next - &f.P_inf).amax() <= 1e-12 * f.P_inf.amax());
}

#[test]
fn divergent_steps_are_rejected_at_the_step_key() {
    let src = include_str!("../../specs/paper-faithful.toml").replace("step = 0.04", "step = 1.5");
    let diags = lower(&load(&src).unwrap()).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert!(
        d.message
            .starts_with("`mpc.step` = 1.5 is too large: it must be below 2/L"),
        "{}",
        d.message
    );
    assert_eq!(&src[d.span.clone().unwrap()], "1.5");
    let fgm = include_str!("../../specs/paper.toml").replace("step = \"auto\"", "step = 0.8");
    let d = lower(&load(&fgm).unwrap()).unwrap_err();
    assert!(d
        .iter()
        .next()
        .unwrap()
        .message
        .contains("below (2+2β)/((1+2β)L)"));
    // 0.7 is above 1/L ≈ 0.49 but inside the fast gradient method's region (about 1.53/L): accepted.
    let fgm = include_str!("../../specs/paper.toml").replace("step = \"auto\"", "step = 0.7");
    assert!(lower(&load(&fgm).unwrap()).is_ok());
}

#[test]
fn indefinite_weights_are_rejected() {
    let src = include_str!("../../specs/paper.toml").replace(
        "q = [150, 150, 150, 5, 5, 5]",
        "q = [[1, 2, 0, 0, 0, 0], [2, 1, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, 0, 1, 0, 0], [0, 0, 0, 0, 1, 0], [0, 0, 0, 0, 0, 1]]",
    );
    let diags = lower(&load(&src).unwrap()).unwrap_err();
    assert!(diags.iter().any(|d| d
        .message
        .starts_with("`mpc.q` must be positive semidefinite")));
}

#[test]
fn values_beyond_the_scalar_type_are_located_errors() {
    let src = include_str!("../../specs/paper.toml")
        .replace("u_max = [10, 10, 10]", "u_max = [10, 1e300, 10]");
    let diags = lower(&load(&src).unwrap()).unwrap_err();
    let d = diags.iter().next().unwrap();
    assert!(
        d.message
            .starts_with("the upper input bounds would overflow f32"),
        "{}",
        d.message
    );
    assert_eq!(&src[d.span.clone().unwrap()], "[10, 1e300, 10]");
    let f64_src = src.replace("scalar = \"f32\"", "scalar = \"f64\"");
    assert!(lower(&load(&f64_src).unwrap()).is_ok());
}

/// The first message of a spec's lowering errors, and the text its span covers.
fn first_error(src: &str) -> (String, String) {
    let Err(diags) = lower(&load(src).unwrap()) else {
        panic!("the spec was accepted");
    };
    let d = diags.iter().next().unwrap();
    let at = d.span.clone().map_or(String::new(), |s| src[s].to_string());
    (d.message.clone(), at)
}

#[test]
fn an_indefinite_weight_cannot_hide_behind_a_large_entry() {
    // Eigenvalues ≈ 1e12 and −0.44 (the second row has 1 on the diagonal and 1.2e6 beside it): a tolerance
    // relative to the largest eigenvalue (1e-12·1e12 = 1) used to accept it.
    let src = include_str!("../../specs/paper.toml").replace(
        "q = [150, 150, 150, 5, 5, 5]",
        "q = [[1e12, 1.2e6, 0, 0, 0, 0], [1.2e6, 1, 0, 0, 0, 0], [0, 0, 150, 0, 0, 0], [0, 0, 0, 5, 0, 0], [0, 0, 0, 0, 5, 0], [0, 0, 0, 0, 0, 5]]",
    );
    let (message, at) = first_error(&src);
    assert!(
        message.starts_with("`mpc.q` must be positive semidefinite"),
        "{message}"
    );
    assert!(at.starts_with("[[1e12"), "{at}");
    // A zero weight is fine; a zero diagonal with an off-diagonal entry is not.
    let zero = include_str!("../../specs/paper.toml").replace(
        "q = [150, 150, 150, 5, 5, 5]",
        "q = [150, 150, 150, 0, 5, 5]",
    );
    assert!(lower(&load(&zero).unwrap()).is_ok());
}

#[test]
fn a_plant_the_inputs_cannot_move_is_not_stabilizable() {
    let src = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0], [0]]
c = [[1, 0]]
[mpc]
horizon = 10
iterations = 20
q = [1, 1]
r = [1]
u_min = [-1]
u_max = [1]
[kalman]
q = [[0.01, 0], [0, 0.01]]
r = [[0.01]]
"#;
    let (message, at) = first_error(src);
    assert_eq!(
        message,
        "input 0 moves nothing: column 0 of `model.b` is zero"
    );
    assert_eq!(at, "[[0], [0]]");
    // An input that moves only a stable mode leaves the integrator unreachable.
    let partial = src
        .replace("a = [[1, 0.1], [0, 1]]", "a = [[1, 0], [0, 0.5]]")
        .replace("b = [[0], [0]]", "b = [[0], [1]]");
    let (message, at) = first_error(&partial);
    assert!(
        message.starts_with("the plant is not stabilizable: its mode λ = 1"),
        "{message}"
    );
    assert_eq!(at, "[[0], [1]]");
    // Stabilizable with the input on the velocity.
    assert!(lower(&load(&src.replace("b = [[0], [0]]", "b = [[0], [0.1]]")).unwrap()).is_ok());
}

#[test]
fn auto_iterations_never_exceed_the_fixed_count_limit() {
    // Algorithm 1 at α = 0.001 on the paper's H: (1 − αμ)^k ≤ 1e-12 needs about 9e4 / 0.3 iterations.
    let src = include_str!("../../specs/paper-faithful.toml")
        .replace("tolerance = 0.7", "tolerance = 1e-12")
        .replace("iterations = 30", "iterations = \"auto\"")
        .replace("step = 0.04", "step = 0.0001");
    let (message, at) = first_error(&src);
    assert!(
        message.starts_with("`iterations = \"auto\"` would need "),
        "{message}"
    );
    assert!(message.ends_with("above the limit of 100000"), "{message}");
    assert_eq!(at, "\"auto\"");
}

#[test]
fn a_numerically_singular_hessian_is_an_error_at_r() {
    // Two inputs that act identically, weighted 1e-30: H = 2(SuᵀQSu + R) has eigenvalues of 2e-30 beside
    // ones near 1, a condition number past 1/ε (this used to panic in the certificate).
    let src = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005, 0.005], [0.1, 0.1]]
c = [[1, 0]]
[mpc]
horizon = 5
iterations = 20
q = [1, 1]
r = [1e-30, 1e-30]
u_min = [-1, -1]
u_max = [1, 1]
[kalman]
q = [[0.01, 0], [0, 0.01]]
r = [[0.01]]
"#;
    let (message, at) = first_error(src);
    assert!(
        message.starts_with("the Hessian H is numerically singular"),
        "{message}"
    );
    assert_eq!(at, "[1e-30, 1e-30]");
    // The same plant with a reasonable input weight builds.
    assert!(lower(&load(&src.replace("r = [1e-30, 1e-30]", "r = [0.1, 0.1]")).unwrap()).is_ok());
}

#[test]
fn symmetry_up_to_rounding_is_accepted_and_symmetrized_with_a_warning() {
    let paper = include_str!("../../specs/paper.toml");
    let full = |off: &str| {
        paper.replace(
            "qf_scale = 50",
            &format!("qf = [[7500, {off}, 0, 0, 0, 0], [0.5, 7500, 0, 0, 0, 0], [0, 0, 7500, 0, 0, 0], [0, 0, 0, 250, 0, 0], [0, 0, 0, 0, 250, 0], [0, 0, 0, 0, 0, 250]]"),
        )
    };
    // A Riccati solution printed to ten digits: 0.5 against 0.5000000001 (asymmetry 1.3e-14 of 7500).
    let g = codegen::generate_from_source(&full("0.5000000001"), &codegen::Opt::default()).unwrap();
    assert_eq!(g.problem.qp.Qf, g.problem.qp.Qf.transpose());
    assert!((g.problem.qp.Qf[(0, 1)] - 0.50000000005).abs() < 1e-15);
    // 1e-6 of the pair's scale is a typo, not rounding.
    let load = mpc_spec::load(&full("0.5075")).unwrap_err();
    assert!(load
        .iter()
        .next()
        .unwrap()
        .message
        .starts_with("`mpc.qf` must be symmetric"));
    // Between 1e-12 and 1e-9 of the scale: accepted, with a warning naming the key.
    let g = codegen::generate_from_source(&full("0.500005"), &codegen::Opt::default()).unwrap();
    let w = g.warnings.iter().next().expect("a warning");
    assert!(
        w.message.starts_with("`mpc.qf` is not exactly symmetric"),
        "{}",
        w.message
    );
}

#[test]
fn a_sampling_time_f64_cannot_resolve_is_an_error_at_dt() {
    let paper = include_str!("../../specs/paper.toml");
    let with_dt = |dt: &str| paper.replace("dt = 0.0128", &format!("dt = {dt}"));
    // Δt²/2 overflows.
    let src = with_dt("1e300");
    let (message, at) = first_error(&src);
    assert!(
        message.starts_with("`model.dt` = 1e300 is too large for f64: the discrete model's Δt²/2"),
        "{message}"
    );
    assert_eq!(at, "1e300");
    // Δt²/2 underflows next to Δt: [G, FG] is singular (it used to run a million Riccati steps first).
    let src = with_dt("1e-300");
    let (message, at) = first_error(&src);
    assert!(
        message.starts_with("`model.dt` = 1e-300 is too small for f64"),
        "{message}"
    );
    assert_eq!(at, "1e-300");
    // κ([G, FG]) ≈ 2/Δt: its square passes 1/ε below Δt ≈ 3e-8, and 2.5·Δt above about 3e7.
    assert!(first_error(&with_dt("1e-8"))
        .0
        .starts_with("`model.dt` = 1e-8 is too small"));
    assert!(
        first_error(&with_dt("1e8"))
            .0
            .starts_with("`model.dt` = 100000000 is too large")
            || first_error(&with_dt("1e8"))
                .0
                .starts_with("`model.dt` = 1e8 is too large")
    );
    assert!(lower(&load(&with_dt("0.001")).unwrap()).is_ok());
}

#[test]
fn process_noise_that_misses_an_integrator_is_an_error_before_the_riccati_recursion() {
    // σ_a² underflows to 0: the double integrator's modes at 1 get no noise, and the recursion would only
    // settle as 1/k (a million steps, then "no steady state").
    let src = include_str!("../../specs/paper.toml").replace("sigma_a = 0.15", "sigma_a = 1e-300");
    let (message, at) = first_error(&src);
    assert!(
        message.starts_with("`kalman.sigma_a` = 1e-300 is too small"),
        "{message}"
    );
    assert_eq!(at, "1e-300");
    let linear = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1], [0, 1]]
b = [[0.005], [0.1]]
c = [[1, 0]]
[mpc]
horizon = 10
iterations = 40
q = [1, 1]
r = [0.1]
u_min = [-1]
u_max = [1]
[kalman]
q = [[0, 0], [0, 0]]
r = [[0.01]]
"#;
    let (message, at) = first_error(linear);
    assert!(
        message.starts_with("the Kalman filter has no steady state: the process noise does not reach the mode λ = 1"),
        "{message}"
    );
    assert_eq!(at, "[[0, 0], [0, 0]]");
    // Noise on the velocity alone reaches the position through the dynamics.
    let reached = linear.replace("q = [[0, 0], [0, 0]]", "q = [[0, 0], [0, 0.01]]");
    assert!(lower(&load(&reached).unwrap()).is_ok());
}

#[test]
fn an_overflowing_hessian_is_blamed_on_the_weight_that_causes_it() {
    let paper = include_str!("../../specs/paper.toml");
    for (old, new, key) in [
        ("r = [0.15, 0.15, 0.15]", "r = 1e300", "1e300"),
        ("qf_scale = 50", "qf_scale = 1e300", "1e300"),
        ("q = [150, 150, 150, 5, 5, 5]", "q = 1e300", "1e300"),
    ] {
        let src = paper.replace(old, new);
        let (message, at) = first_error(&src);
        assert!(
            message.starts_with("the Hessian H would overflow f32"),
            "{new}: {message}"
        );
        assert_eq!(at, key, "{new}");
        let line = src[..src.find(new).unwrap()].lines().count() + 1;
        let (diag_line, _) = lower(&load(&src).unwrap())
            .unwrap_err()
            .iter()
            .next()
            .unwrap()
            .line_col(&src)
            .unwrap();
        assert_eq!(diag_line, line, "{new}");
    }
}

#[test]
fn a_model_whose_powers_overflow_is_an_error_at_a() {
    let src = r#"
[model]
type = "linear"
dt = 0.1
a = [[1e200, 0.1], [0, 1]]
b = [[0.005], [0.1]]
c = [[1, 0]]
[mpc]
horizon = 10
iterations = 40
q = [1, 1]
r = [0.1]
u_min = [-1]
u_max = [1]
[kalman]
q = [[0.0001, 0], [0, 0.01]]
r = [[0.01]]
"#;
    let (message, at) = first_error(src);
    assert!(
        message.starts_with("`model.a` has a mode with |λ| = 1.000e200"),
        "{message}"
    );
    assert_eq!(at, "[[1e200, 0.1], [0, 1]]");
    // A mode of 10 grows by 1e10 over the horizon: within range, and reported as what it is.
    let grows = src.replace("1e200", "10");
    if let Err(diags) = lower(&load(&grows).unwrap()) {
        assert!(diags
            .iter()
            .all(|d| !d.message.starts_with("`model.a` has a mode")));
    }
}

/// The cost a spec with outputs and moves defines, summed along a simulated prediction: stage k = 1…N
/// weighs (C_z x_k − r_k) with `q` (the terminal with `qf`, on the outputs, or on x_N − C_z⁺ r_N when `qf`
/// is state-sized), every input with `r`, every move u_k − u_{k−1} (u_{−1} the last input) with `r_du`.
fn cost_by_simulation(
    spec: &mpc_spec::Spec,
    p: &codegen::Problem,
    x0: &nalgebra::DVector<f64>,
    refs: &[nalgebra::DVector<f64>],
    last: &nalgebra::DVector<f64>,
    U: &nalgebra::DVector<f64>,
) -> f64 {
    let m = &spec.mpc;
    let dense = |M: &mpc_spec::Matrix| DMatrix::from_row_slice(M.rows, M.cols, &M.data);
    let Cz = dense(m.outputs.as_ref().unwrap());
    let (W, Wf, R) = (dense(&m.q), dense(&m.qf), dense(&m.r));
    let R_du = dense(m.r_du.as_ref().unwrap());
    let (nu, N) = (p.nu, m.horizon);
    let mut x = x0.clone();
    let mut before = last.clone();
    let mut J = 0.0;
    for (k, r) in refs.iter().enumerate().take(N) {
        let u = U.rows(k * nu, nu).into_owned();
        x = &p.F * &x + &p.G * &u;
        J += if k + 1 < N {
            let e = &Cz * &x - r;
            (e.transpose() * &W * &e)[(0, 0)]
        } else if m.qf_on_state {
            let e = &x - Cz.clone().pseudo_inverse(1e-12).unwrap() * r;
            (e.transpose() * &Wf * &e)[(0, 0)]
        } else {
            let e = &Cz * &x - r;
            (e.transpose() * &Wf * &e)[(0, 0)]
        };
        let du = &u - &before;
        J += (u.transpose() * &R * &u)[(0, 0)] + (du.transpose() * &R_du * &du)[(0, 0)];
        before = u;
    }
    J
}

#[test]
fn outputs_and_moves_condense_to_the_cost_they_define() {
    use nalgebra::DVector;
    let outputs = include_str!("../../tests/specs/two-mass-outputs.toml");
    let filtered = include_str!("../../tests/specs/two-mass-filtered.toml");
    let on_state = outputs.replace("r = 0\n", "r = 0\nqf = [1, 20, 3, 4]\n");
    let mut seed = 0x2545_f491_4f6c_dd1d_u64;
    let mut random = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    for text in [outputs, filtered, on_state.as_str()] {
        let spec = load(text).unwrap();
        let p = lower(&spec).unwrap();
        assert!(p.has_moves());
        let (nx, nu, nz, N) = (p.nx, p.nu, p.qp.nz, p.qp.N);
        for _ in 0..20 {
            let x0 = DVector::from_fn(nx, |_, _| random());
            let refs: Vec<DVector<f64>> = (0..N)
                .map(|_| DVector::from_fn(nz, |_, _| random()))
                .collect();
            let last = DVector::from_fn(nu, |_, _| random());
            let U = DVector::from_fn(N * nu, |_, _| random());
            let R = DVector::from_iterator(N * nz, refs.iter().flat_map(|r| r.iter().copied()));
            let f = &p.qp.Fx * &x0 - &p.qp.Fr * R + &p.qp.Fu * &last;
            // J(U) − J(0) = ½UᵀHU + fᵀU exactly: the quadratic and the linear term of the condensed QP.
            let quadratic = 0.5 * (U.transpose() * &p.qp.H * &U)[(0, 0)] + f.dot(&U);
            let zero = DVector::zeros(N * nu);
            let simulated = cost_by_simulation(&spec, &p, &x0, &refs, &last, &U)
                - cost_by_simulation(&spec, &p, &x0, &refs, &last, &zero);
            let scale = cost_by_simulation(&spec, &p, &x0, &refs, &last, &U)
                .abs()
                .max(1.0);
            assert!(
                (quadratic - simulated).abs() <= 1e-10 * scale,
                "condensed {quadratic} against simulated {simulated}"
            );
        }
    }
}

#[test]
fn zero_input_weight_needs_moves_and_a_definite_hessian() {
    let outputs = include_str!("../../tests/specs/two-mass-outputs.toml");
    // Without `r_du`, r = 0 is refused at `mpc.r`, pointing at the move weight.
    let errors = mpc_spec::load(&outputs.replace("r_du = 1\n", "")).unwrap_err();
    let message = format!("{errors:?}");
    assert!(
        message.contains("`mpc.r` must be positive definite"),
        "{message}"
    );
    assert!(message.contains("r_du"), "{message}");
    // An input that neither the outputs nor any weight sees leaves H singular: a located error at `mpc.r`.
    let free_input = r#"
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
"#;
    // The spec's check sees it before the Hessian is formed: the error names both keys, on `r_du`'s
    // entry with `r`'s beside it (issue 31, "errors that blame the wrong key").
    let errors = mpc_spec::load(free_input).unwrap_err();
    let d = errors.iter().next().unwrap();
    assert!(
        d.message.starts_with(
            "input 1 has no weight: its entries of `mpc.r` and `mpc.r_du` are both zero"
        ),
        "{}",
        d.message
    );
    assert_eq!(&free_input[d.span.clone().unwrap()], "[1, 0]");
    assert_eq!(&free_input[d.related[0].0.clone()], "[0, 0]");
}
