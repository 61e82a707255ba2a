//! The constraints of `[mpc]` lowered onto the condensed QP (`codegen::constraints`) and the interior-point
//! method's sampled certificate (`codegen::sampling`).
#![allow(non_snake_case)]

use nalgebra::DVector;

/// A two-input plant with every kind of row: state bounds (one soft pair), move bounds, a group on the
/// state and input (with `au`) and a soft group on the state only, and an offset-free filter.
const ROWS: &str = r#"
[model]
type = "linear"
dt = 0.1
a = [[1, 0.1, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0.1], [0, 0, 0, 0.9]]
b = [[0.005, 0], [0.1, 0], [0, 0.005], [0, 0.1]]
c = [[1, 0, 0, 0], [0, 0, 1, 0]]
[mpc]
horizon = 6
iterations = "auto"
method = "ipm"
q = [10, 1, 5, 1]
r = [0.1, 0.3]
u_min = [-1, -2]
u_max = [1, 0.5]
x_min = [-inf, -1.5, -inf, -inf]
x_max = [2, 1.5, inf, inf]
x_soft = 100
du_min = [-0.5, -inf]
du_max = [0.5, 1]

[[mpc.constraint]]
ax = [[1, 0, 1, 0]]
au = [[0, 1]]
lower = [-3]
upper = [3]

[[mpc.constraint]]
ax = [[0, 1, 0, -1], [0, 0, 1, 0]]
upper = [2, inf]
lower = [-inf, -2]
soft = 50

[mpc.region]
x_min = [-1, -1, -1, -1]
x_max = [1, 1, 1, 1]
samples = 10
sequences = 1
steps = 10

[kalman]
q = [[0.01, 0, 0, 0], [0, 0.01, 0, 0], [0, 0, 0.01, 0], [0, 0, 0, 0.01]]
r = [[0.04, 0], [0, 0.04]]
disturbance = [0.01, 0.01]
[codegen]
scalar = "f64"
"#;

/// Each row's value A·(U, 0) + Wx·x0 + Wd·d + Wu·u₋₁ is what it constrains along a simulated prediction
/// (x⁺ = F x + G (u + d)), at the stage its slot stands for.
#[test]
fn rows_are_the_constrained_quantities_of_the_prediction() {
    let spec = mpc_spec::load(ROWS).unwrap();
    let p = codegen::lower(&spec).unwrap();
    let rows = &p.qp.rows;
    let (nx, nu, N) = (p.nx, p.nu, p.qp.N);
    let n = N * nu;
    assert_eq!(rows.len(), rows.per_slot * N);
    // Slacks: the two bounded states (x0 by x_max, x1 by both) and the two rows of the soft group.
    assert_eq!(rows.slacks(), 4);
    let x0 = DVector::from_vec(vec![0.3, -0.2, 0.5, 0.1]);
    let d = DVector::from_vec(vec![0.05, -0.1]);
    let last = DVector::from_vec(vec![0.2, -0.4]);
    let U = DVector::from_fn(n, |i, _| ((i * 7) % 5) as f64 * 0.1 - 0.2);
    let mut x = vec![x0.clone()];
    for k in 0..N {
        let u = U.rows(k * nu, nu);
        x.push(&p.F * &x[k] + &p.G * (u + &d));
    }
    let input = |k: isize| -> DVector<f64> {
        if k < 0 {
            last.clone()
        } else {
            U.rows(k as usize * nu, nu).into_owned()
        }
    };
    let groups = &spec.mpc.constraints.rows;
    let offset = rows.offset(&x0, &d, &last);
    for r in 0..rows.len() {
        let (slot, kind) = (r / rows.per_slot, &rows.kinds[r % rows.per_slot]);
        let value = rows.A.row(r).columns(0, n).transpose().dot(&U) + offset[r];
        let expected = match kind {
            codegen::constraints::RowKind::State { index, .. } => x[slot + 1][*index],
            codegen::constraints::RowKind::Move { index } => {
                input(slot as isize)[*index] - input(slot as isize - 1)[*index]
            }
            codegen::constraints::RowKind::Group { group, row, .. } => {
                let g = &groups[*group];
                let ax = DVector::from_fn(nx, |j, _| g.ax.get(*row, j));
                let au = DVector::from_fn(nu, |j, _| g.au.get(*row, j));
                if au.iter().any(|v| *v != 0.0) {
                    ax.dot(&x[slot]) + au.dot(&input(slot as isize))
                } else {
                    ax.dot(&x[slot + 1])
                }
            }
        };
        assert!(
            (value - expected).abs() <= 1e-12,
            "row {r} ({}) at slot {slot}: {value} against {expected}",
            kind.name()
        );
        // A soft row's slack enters with the sign that relaxes it.
        let slack = rows.A.row(r).columns(n, rows.slacks()).into_owned();
        assert_eq!(rows.soft[r], slack.iter().any(|v| *v != 0.0));
        if rows.soft[r] {
            let sign = slack.iter().copied().find(|v| *v != 0.0).unwrap();
            if rows.upper[r].is_finite() {
                assert_eq!(sign, -1.0);
            } else {
                assert_eq!(sign, 1.0);
            }
        }
    }
}

/// `iterations = "auto"` is the worst count the sample needed plus the stated margin, and the sample
/// reaches the accuracy at it.
#[test]
fn auto_iterations_are_the_worst_observed_plus_the_margin() {
    let p = codegen::lower(&mpc_spec::load(ROWS).unwrap()).unwrap();
    let e = p.qp.evidence.as_ref().unwrap();
    let worst = e.cold_worst.max(e.warm_worst);
    assert_eq!(e.worst_needed, worst);
    assert_eq!(p.qp.iterations, worst + codegen::sampling::margin(worst));
    assert!(e.auto && e.worst_error <= p.qp.accuracy && e.worst_violation <= p.qp.accuracy);
    // 16 corners (nx = 4), 10 draws, one sequence of 10 steps.
    assert_eq!((e.corners, e.cold_cases + e.infeasible_cases), (16, 26));
    assert_eq!(e.warm_steps, 10);
    // The region's references default to the tracked outputs (the state) over the state region.
    assert_eq!(e.region.reference_min, vec![-1.0; 4]);
}

/// A state without a range (no bounds on both sides, no `[mpc.region]` entry) is refused, located.
#[test]
fn a_state_without_a_range_is_a_located_error() {
    let text = ROWS.replace(
        "[mpc.region]\nx_min = [-1, -1, -1, -1]\nx_max = [1, 1, 1, 1]\n",
        "[mpc.region]\n",
    );
    assert_ne!(text, ROWS);
    let spec = mpc_spec::load(&text).unwrap();
    let diags = codegen::lower(&spec).unwrap_err();
    let d = &diags.0[0];
    assert!(d.message.contains("state 0 has no range"), "{}", d.message);
    assert_eq!(&text[d.span.clone().unwrap()], "region");
}

/// The exact reference of the sample agrees with a direct dense solve where no row is active: the
/// unconstrained minimiser −H⁻¹f.
#[test]
fn inactive_rows_leave_the_unconstrained_solution() {
    let p = codegen::lower(&mpc_spec::load(ROWS).unwrap()).unwrap();
    let qp = &p.qp;
    let n = qp.N * p.nu;
    let f = DVector::from_fn(n, |i, _| 0.01 * (i as f64 - 3.0));
    let U = -qp.H.clone().cholesky().unwrap().solve(&f);
    let offset = DVector::zeros(qp.rows.len());
    let problem = codegen::ipm::mpc_qp(qp, &f, &offset);
    let r = codegen::ipm::solve(&problem, 1e-10, 100);
    assert_eq!(r.status, codegen::ipm::Status::Converged);
    assert!((r.z.rows(0, n) - &U).amax() <= 1e-8);
    assert!(r.z.rows(n, qp.rows.slacks()).amax() <= 1e-8);
}

/// The certificate's sample counts against the build budget: one too large to run is refused at
/// `[mpc.region]` (from its predicted cost, which `sampling::certify` checks before drawing anything).
#[test]
fn a_sample_above_the_build_budget_is_refused() {
    let text = ROWS.replace(
        "samples = 10\nsequences = 1\nsteps = 10",
        "samples = 10000\nsequences = 100\nsteps = 1000",
    );
    assert_ne!(text, ROWS);
    let spec = mpc_spec::load(&text).unwrap();
    let diags = codegen::lower(&spec).unwrap_err();
    let d = &diags.0[0];
    assert!(
        d.message.contains("certificate would take"),
        "{}",
        d.message
    );
    assert_eq!(&text[d.span.clone().unwrap()], "region");
}

/// More than a quarter of the region's draws infeasible is a warning naming the region's corners to
/// shrink; a quarter or fewer is not. The pendulum on a cart with |θ| ≤ 0.2 from angular rates up to 12
/// rad/s (18 of 66 cases infeasible) and up to 9 rad/s (16 of 66, under a quarter).
#[test]
fn a_region_mostly_infeasible_warns_at_its_corners() {
    let pendulum = include_str!("../../tests/specs/pendulum-lqr.toml");
    let region = |rate: &str| {
        let src = pendulum
            .replace(
                "x_min = [-0.5, -0.2, -0.05, -0.2]",
                &format!("x_min = [-0.5, -1, -0.19, -{rate}]"),
            )
            .replace(
                "x_max = [0.5, 0.2, 0.05, 0.2]",
                &format!("x_max = [0.5, 1, 0.19, {rate}]"),
            );
        assert_ne!(src, pendulum);
        let spec = mpc_spec::load(&src).unwrap();
        let g = codegen::generate(&spec, &codegen::Opt::default()).unwrap();
        let e = g.problem.qp.evidence.clone().unwrap();
        let warning = g
            .warnings
            .iter()
            .find(|d| d.message.contains("are infeasible"))
            .map(|d| {
                (
                    d.message.clone(),
                    src[d.span.clone().unwrap()].to_string(),
                    d.note.clone(),
                )
            });
        (
            e.infeasible_cases,
            e.cold_cases + e.infeasible_cases,
            warning,
        )
    };
    let (infeasible, drawn, warning) = region("12");
    assert!(4 * infeasible > drawn, "{infeasible} of {drawn}");
    let (message, at, note) = warning.expect("a warning");
    assert!(
        message.starts_with(&format!("{infeasible} of the {drawn} cold cases")),
        "{message}"
    );
    assert_eq!(at, "[0.5, 1, 0.19, 12]");
    assert!(note.unwrap().contains("`[mpc.region]`'s `x_min`/`x_max`"));
    let (infeasible, drawn, warning) = region("9");
    assert!(
        infeasible > 0 && 4 * infeasible <= drawn,
        "{infeasible} of {drawn}"
    );
    assert_eq!(warning, None);
}
