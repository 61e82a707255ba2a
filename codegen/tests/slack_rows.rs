//! Rows that cannot bind over `[mpc.region]` (issue 33, rows pruned by proof;
//! `codegen::solver::active_set::slack_rows`): the proof against hover's predictions formed here from its
//! model as written, apart from the compiler's condensed rows, the pruned kernel against the full one inside the region and outside it, and a
//! closed-loop flight that starts outside the region, where the dropped rows bind.

use codegen::solver::active_set::exact::Parameters;
use codegen::solver::active_set::mpc::{control_step, prepare, prepare_with, Caps};
use codegen::solver::active_set::{solve, Row, Status};
use nalgebra::{DMatrix, DVector};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

const HOVER: &str = include_str!("../../specs/hover.toml");

/// Hover lowered and certified (once for the three tests: the certificate is what takes the time), and
/// its parameters.
fn hover() -> (codegen::Problem, Parameters) {
    static LOWERED: std::sync::OnceLock<codegen::Problem> = std::sync::OnceLock::new();
    let spec = mpc_spec::load(HOVER).unwrap();
    let p = LOWERED
        .get_or_init(|| codegen::lower(&spec).unwrap())
        .clone();
    let region = codegen::sampling::resolve_region(&spec, &p, "test").unwrap();
    let parameters = Parameters::of(&p, &region);
    (p, parameters)
}

/// Hover's discrete model as written (`type = "linear"`, discrete).
fn model(spec: &mpc_spec::Spec) -> (DMatrix<f64>, DMatrix<f64>) {
    let mpc_spec::ModelKind::Linear { a, b, .. } = &spec.model.kind else {
        panic!("hover's model is linear");
    };
    let dense = |m: &mpc_spec::Matrix| DMatrix::from_row_slice(m.rows, m.cols, &m.data);
    (dense(a), dense(b))
}

/// Per stage k = 1 … N, per state i, the least and the most x_k[i].
type Reach = Vec<Vec<(f64, f64)>>;

/// Per predicted state x_k[i] (k = 1 … N), its least and most value over x₀ in the region's box and
/// every input within the box: x_k = Aᵏx₀ + Σ_j Aᵏ⁻¹⁻ʲ·B·u_j, by interval arithmetic; and the state
/// bounds.
fn state_reach() -> (Reach, Vec<f64>, Vec<f64>) {
    let spec = mpc_spec::load(HOVER).unwrap();
    let (a, b) = model(&spec);
    let (c, region) = (&spec.mpc.constraints, &spec.mpc.region);
    let n = spec.mpc.horizon;
    let (u_min, u_max) = (spec.mpc.u_min.clone(), spec.mpc.u_max.clone());
    let (x_min, x_max) = (c.x_min.clone(), c.x_max.clone());
    let (r_min, r_max) = (region.x_min.clone(), region.x_max.clone());
    let interval = |m: &DMatrix<f64>, lo: &[f64], hi: &[f64], i: usize| {
        (0..lo.len()).fold((0.0, 0.0), |(l, h), j| {
            let (p, q) = (m[(i, j)] * lo[j], m[(i, j)] * hi[j]);
            (l + p.min(q), h + p.max(q))
        })
    };
    let nx = a.nrows();
    let mut reach = Vec::new();
    let mut power = DMatrix::identity(nx, nx);
    let mut inputs: Vec<DMatrix<f64>> = Vec::new();
    for _ in 1..=n {
        // x_k's maps: Aᵏ on x₀, and Aᵏ⁻¹⁻ʲ·B on u_j (the previous maps times A, then B on the newest).
        inputs = inputs.iter().map(|m| &a * m).collect();
        inputs.push(b.clone());
        power = &a * power;
        reach.push(
            (0..nx)
                .map(|i| {
                    let (mut lo, mut hi) = interval(&power, &r_min, &r_max, i);
                    for m in &inputs {
                        let (l, h) = interval(m, &u_min, &u_max, i);
                        lo += l;
                        hi += h;
                    }
                    (lo, hi)
                })
                .collect(),
        );
    }
    (reach, x_min, x_max)
}

/// The rows the build drops are hover's state bounds that no input within its box can reach from its
/// region, and every state bound that stays a thousandth inside its reach is dropped.
#[test]
fn hovers_dropped_rows_are_the_state_bounds_its_inputs_cannot_reach() {
    let (p, _) = hover();
    let slack = &p.qp.evidence.as_ref().unwrap().slack_rows;
    let rows = &p.qp.rows;
    let (reach, x_min, x_max) = state_reach();
    let mut proved = 0;
    for r in 0..rows.A.nrows() {
        let (slot, within) = (r / rows.per_slot, r % rows.per_slot);
        let codegen::lower::constraints::RowKind::State { index: i, .. } = rows.kinds[within]
        else {
            panic!("hover's rows are its state bounds");
        };
        // Slot j bounds x_{j+1}.
        let (lo, hi) = reach[slot][i];
        let dropped = slack.contains(&r);
        if dropped {
            assert!(
                lo >= x_min[i] - 1e-9 && hi <= x_max[i] + 1e-9,
                "row {r} (x_{}[{i}]) dropped, but reaches [{lo}, {hi}]",
                slot + 1
            );
        }
        if lo >= x_min[i] + 1e-3 && hi <= x_max[i] - 1e-3 {
            proved += 1;
            assert!(
                dropped,
                "row {r} (x_{}[{i}]) within [{lo}, {hi}] kept",
                slot + 1
            );
        }
    }
    println!("hover: {} rows dropped, {proved} proved here", slack.len());
    assert_eq!(slack.len(), 40);
}

/// θ in the region's box, uniformly.
fn draw(parameters: &Parameters, rng: &mut ChaCha8Rng) -> Vec<f64> {
    (0..parameters.len())
        .map(|j| {
            let (lo, hi) = (parameters.lo[j], parameters.hi[j]);
            if lo < hi {
                rng.gen_range(lo..hi)
            } else {
                lo
            }
        })
        .collect()
}

/// θ outside hover's region: `height` (past the region's 3), climbing at `climb`, the height asked
/// for 6 (past its bound at 5), the rest at the centre.
fn outside(parameters: &Parameters, height: f64, climb: f64) -> Vec<f64> {
    let at = |name: &str| {
        parameters
            .names
            .iter()
            .position(|n| n == name)
            .unwrap_or_else(|| panic!("no {name} in θ"))
    };
    let mut theta = parameters.centre();
    theta[at("x0[2]")] = height;
    theta[at("x0[8]")] = climb;
    theta[at("r[2]")] = 6.0;
    theta
}

/// Inside the region the pruned kernel scans only the rows that may bind and reaches the full kernel's
/// optimum; outside it, where a dropped row binds, its check of the proof fails, it scans every row,
/// and again reaches the full kernel's optimum, that row active.
#[test]
fn the_pruned_kernel_reaches_the_full_ones_optimum_inside_and_outside_the_region() {
    let (p, parameters) = hover();
    let pruned = prepare(&p.qp).unwrap();
    let full = prepare_with(&p.qp, &[]).unwrap();
    let slack = &p.qp.evidence.as_ref().unwrap().slack_rows;
    let core: usize = pruned.blocks.iter().map(|b| b.packed.core).sum();
    let all = pruned.constraints();
    assert_eq!(all - core, slack.len());
    let solve_both = |theta: &[f64]| {
        let qp = parameters.qp(&p, theta);
        let a = solve(&pruned, &pruned.offsets(&qp).unwrap(), None, 10_000);
        let b = solve(&full, &full.offsets(&qp).unwrap(), None, 10_000);
        assert_eq!(a.status, Status::Solved);
        assert_eq!(b.status, Status::Solved);
        assert!(
            (&a.z - &b.z).amax() < 1e-8 * (1.0 + b.z.amax()),
            "{}",
            (&a.z - &b.z).amax()
        );
        (a, b)
    };
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let (mut pruned_rows, mut full_rows) = (0, 0);
    for _ in 0..200 {
        let (a, b) = solve_both(&draw(&parameters, &mut rng));
        // Every scan of the pruned kernel visited the core alone.
        assert!(a.macs.rows <= a.macs.passes * core, "{:?}", a.macs);
        pruned_rows += a.macs.rows;
        full_rows += b.macs.rows;
    }
    println!("rows scanned over 200 draws: pruned {pruned_rows}, full {full_rows}");
    assert!(pruned_rows < full_rows);
    // Outside: near the height's bound (state 2, bounded at ±5 where the region stops at ±3, the bounds
    // of its first seven stages dropped), climbing (state 8), asked for 6 (past the bound).
    let mut found = false;
    'search: for height in [4.8, 4.9, 4.95] {
        for climb in [0.2, 0.5, 1.0] {
            let theta = outside(&parameters, height, climb);
            let qp = parameters.qp(&p, &theta);
            if solve(&full, &full.offsets(&qp).unwrap(), None, 10_000).status != Status::Solved {
                continue;
            }
            let (a, _) = solve_both(&theta);
            let binds = a.working_set.0.iter().any(|s| match s.row {
                Row::General(r) => slack.contains(&r),
                Row::Bound(_) => false,
            });
            if binds {
                assert!(
                    a.macs.rows > a.macs.passes * core,
                    "the failed proof scans every row"
                );
                println!("{height} high, climbing at {climb}: a dropped row binds");
                found = true;
                break 'search;
            }
        }
    }
    assert!(found, "no dropped row binds at the states tried");
}

/// A closed-loop flight of hover from outside its region (4.8 high, past the region's 3, climbing at 0.5,
/// asked for 6, past the bound at 5): each step's plan is the full kernel's, the bounds hold, and the
/// dropped rows bind on the way (the height held at 5).
#[test]
fn hover_flies_from_outside_its_region_with_the_dropped_rows_back_in() {
    let (p, parameters) = hover();
    let qp = &p.qp;
    let pruned = prepare(qp).unwrap();
    let full = prepare_with(qp, &[]).unwrap();
    let (a, b) = model(&mpc_spec::load(HOVER).unwrap());
    let nx = p.nx;
    let start = outside(&parameters, 4.8, 0.5);
    let mut x = DVector::from_column_slice(&start[..nx]);
    let slack = &p.qp.evidence.as_ref().unwrap().slack_rows;
    let mut bound_binds = false;
    let caps = Caps::of(qp);
    let n_plan = qp.Nc * p.nu;
    let (mut plan_pruned, mut plan_full) = (DVector::zeros(n_plan), DVector::zeros(n_plan));
    let (mut start_pruned, mut start_full) = (None, None);
    for k in 0..40 {
        let mut theta = start.clone();
        theta[..nx].copy_from_slice(x.as_slice());
        let (f, offset) = parameters.data(&p, &theta);
        let step = |prepared, start: &Option<_>, plan: &DVector<f64>| {
            control_step(
                qp,
                prepared,
                &f,
                &offset,
                start.as_ref(),
                plan,
                caps,
                false,
                mpc_spec::Scalar::F64,
            )
        };
        let s = step(&pruned, &start_pruned, &plan_pruned);
        let t = step(&full, &start_full, &plan_full);
        assert_eq!(
            s.fallback,
            codegen::solver::constrained::Fallback::Solved,
            "step {k}"
        );
        assert!(
            (&s.plan - &t.plan).amax() < 1e-8,
            "step {k}: {}",
            (&s.plan - &t.plan).amax()
        );
        (start_pruned, start_full) = (s.next_start(), t.next_start());
        (plan_pruned, plan_full) = (s.plan.clone(), t.plan.clone());
        bound_binds |= s.outcome.working_set.0.iter().any(|a| match a.row {
            Row::General(r) => slack.contains(&r),
            Row::Bound(_) => false,
        });
        let u = s.plan.rows(0, p.nu).into_owned();
        x = &a * &x + &b * &u;
        assert!(x.amax() <= 5.0 + 1e-6, "step {k}: {x}");
    }
    assert!(bound_binds, "no dropped row bound on the flight");
    println!("40 steps from outside the region, the height {:.4}", x[2]);
}
