//! Budgets: what building a spec will cost, predicted before the work is spent, and refused with a
//! located error past what a build should take.
//!
//! Two checks, each before the work it predicts:
//! - [`before_lowering`], from the spec's dimensions alone: the bytes of the f64 matrices lowering forms
//!   (the block weight Q_blk is (N·nx)², Su (N·nx)×(N·nu)) and the multiply-adds of the products and
//!   eigenvalue problems. `axes = 1000` would form 7.2 GB; it is refused before any allocation.
//! - [`before_emission`], from the lowered problem's counts: the numbers the module writes (its tables)
//!   and the multiply-adds it unrolls (the filter over the covariance's pattern, an unrolled gradient),
//!   and from them the source size and rustc's time and memory.
//!
//! rustc's cost model is calibrated with `scripts/rustc-cost.sh` (rustc -C opt-level=3 on `mpcc emit` output
//! under `/usr/bin/time`; its table is in the README): tables cost little (the paper at N = 100, 272k
//! numbers in 5.3 MB: about 2.3 s, 220 MB), unrolled code a lot and more than linearly (a dense `linear`
//! plant with a time-varying filter, nx = 12: 13.5k unrolled multiply-adds, about 6 s, 230 MB; nx = 24: 78k,
//! 97-107 s, 1.8 GB). The estimate is t = 1 s + 0.22 s/MB of tables + 4.6 µs·m^1.5 and memory = 120 MB +
//! 19 MB per MB of tables + 230 MB·(m / 13,500)^1.18 for m unrolled multiply-adds: an order of magnitude,
//! which is what a budget needs.
#![allow(non_snake_case)]

use mpc_spec::{Diagnostic, Diagnostics, Emission, Span, Spec};
use serde::Serialize;

/// Bytes of f64 matrices lowering may form.
pub const LOWERING_BYTES: f64 = 2.0 * GIB;
/// Multiply-adds lowering and the certificate may spend (products, eigenvalues, the sample's runs and
/// exact references, ADMM's tuning), as priced: about half a minute on two cores. The most expensive
/// shipped build, hover's f32 ADMM for the M4F (tuning, the residual form's sample, the direct form's
/// bounded attempt), spends about that and takes 33 s in `target/release/mpcc check` here.
pub const LOWERING_MACS: f64 = 1e11;
/// The solver-loop analysis (the closed loop of the fixed-iteration solver, unrolled over every iteration)
/// is skipped above this many multiply-adds; the certificate then says it was not computed.
pub const SOLVER_ANALYSIS_MACS: f64 = 2e9;
/// rustc's predicted memory for the emitted module.
pub const RUSTC_BYTES: f64 = 4.0 * GIB;
/// rustc's predicted time for the emitted module, seconds.
pub const RUSTC_SECONDS: f64 = 300.0;

const GIB: f64 = (1u64 << 30) as f64;
const MB: f64 = 1e6;
/// Bytes of source per number or unrolled term, from the paper at N = 100 (5.33 MB for 272k numbers).
const BYTES_PER_TERM: f64 = 20.0;

/// What building the module is predicted to cost.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct BuildCost {
    /// Bytes of the f64 matrices lowering forms.
    pub lowering_bytes: f64,
    /// Multiply-adds of lowering and of the certificate's analyses.
    pub lowering_macs: f64,
    /// Numbers in the emitted tables.
    pub emitted_numbers: usize,
    /// Multiply-adds unrolled into the emitted code.
    pub emitted_unrolled: usize,
    /// Bytes of the emitted source.
    pub source_bytes: f64,
    /// rustc's time on the module, seconds.
    pub rustc_seconds: f64,
    /// rustc's memory on the module, bytes.
    pub rustc_bytes: f64,
}

/// The dimensions that set the cost: states, inputs, horizon and the filter's states.
#[derive(Clone, Copy, Debug)]
pub struct Dims {
    /// States.
    pub nx: f64,
    /// Inputs.
    pub nu: f64,
    /// Horizon.
    pub N: f64,
    /// The filter's states (with the disturbance).
    pub na: f64,
}

fn dims(spec: &Spec) -> Dims {
    let k = &spec.model.kind;
    let nd = if spec
        .kalman
        .as_ref()
        .is_some_and(|k| k.disturbance.is_some())
    {
        k.nu()
    } else {
        0
    };
    Dims {
        nx: k.nx() as f64,
        nu: k.nu() as f64,
        N: spec.mpc.horizon as f64,
        na: (k.nx() + nd) as f64,
    }
}

/// Bytes and multiply-adds of lowering and the certificate, from the dimensions.
fn lowering(d: Dims) -> (f64, f64) {
    let (nr, nz) = (d.N * d.nx, d.N * d.nu);
    // Q_blk, Su, Sx, R_blk, SuᵀQ_blk, H and its eigen copies, Fx, Fr, the filter's matrices.
    let numbers =
        nr * nr + 2.0 * nr * nz + nr * d.nx + 5.0 * nz * nz + nz * d.nx + 12.0 * d.na * d.na;
    // SuᵀQ_blk, ·Su, ·Sx, the eigenvalues of H (twice) and its inverse, the Riccati and Lyapunov steps.
    let macs =
        nz * nr * nr + nz * nz * nr + nz * nr * d.nx + 25.0 * nz.powi(3) + 1e3 * d.na.powi(3);
    (8.0 * numbers, macs)
}

/// The multiply-adds of the solver-loop analysis: every iteration on an nz × (nx + nz) matrix, then the
/// spectral radius of the (nx + nz)² closed loop.
pub fn solver_analysis_macs(nx: usize, nz: usize, iterations: usize) -> f64 {
    let (nx, nz) = (nx as f64, nz as f64);
    let dim = nx + nz;
    iterations as f64 * nz * nz * dim + 25.0 * dim.powi(3)
}

/// What a case of the sample costs besides the iterations priced for it (drawing it, forming its QP,
/// setting up the exact references), in multiply-adds at the rate the iterations run: on the 2-state
/// `tests/hostile/region-maxima.toml` (110,016 cases, iterations priced at 2.2e10) the sample took about
/// as long as the 1e11 of hover's f32 ADMM (about a minute of CPU in `target/release/mpcc check`).
pub const CASE_OVERHEAD_MACS: f64 = 1e6;

/// Feasibility LPs the exact count of the dual active-set method ([`crate::solver::active_set::exact`])
/// may solve per block before it falls back to the sampled count, unless `[mpc.region] exact_lps` says
/// otherwise: the 2-parameter problem of `codegen/tests/exact_count.rs` needs 3,569 (0.03 s).
pub const EXACT_LPS: usize = 20_000;

/// Parameters (those acting in parallel combined into one coordinate) a block of the dual active-set
/// method's QP may depend on for the exact count to partition it within the build: the regions, and the
/// LPs per region, grow with the dimension. At 3 (paper-limits' x and y blocks) the partition completes
/// in 28,500,000 LPs, 1,349,309 regions, 389 s; at 4 (its height) 15,000,000 LPs gave 457,985 regions
/// in 456 s without completing; at 5-7 (the pendulum,
/// afti16) 5,000 LPs gave 69-101 regions (BENCHMARKS.md, "The exact count"): a block above this is not
/// partitioned, and the sample certifies it.
pub const EXACT_DIMENSION: usize = 3;

/// Iterations one exact reference solve is priced at: the interior-point method run to
/// `sampling::EXACT_TOLERANCE` takes 9-21 on average on the shipped specs (at most 200).
pub const EXACT_ITERATIONS: f64 = 20.0;

/// The multiply-adds of one iteration of the exact reference, the dense interior-point method on a
/// case's QP of `n` unknowns and `m` rows: forming the normal matrix over the m + 2n sides (n² each,
/// halved by symmetry), its Cholesky factor (n³/6), and the products with the rows (a few m·n).
pub fn exact_macs_per_iteration(n: usize, m: usize) -> f64 {
    let (n, m) = (n as f64, m as f64);
    n.powi(3) / 6.0 + (m + 2.0 * n) * n * n / 2.0 + 8.0 * (m + n) * n
}

/// The multiply-adds of one exact reference solve on `qp`'s case QPs, priced at [`EXACT_ITERATIONS`].
pub fn exact_macs(qp: &crate::lower::problem::Qp) -> f64 {
    EXACT_ITERATIONS * exact_macs_per_iteration(qp.H.nrows() + qp.rows.slacks(), qp.rows.len())
}

/// What an ADMM iteration of the certificate's simulation costs beyond the emitted count: the
/// simulation multiplies by the dense C = [I; A] and Cᵀ ((n + m)·n each) and checks the iterate's
/// accuracy against every row (m·n), where the emitted code visits the nonzeros only (on hover the
/// profile puts these at three quarters of the sample's time).
pub fn admm_simulation_overhead(qp: &crate::lower::problem::Qp) -> usize {
    let n = qp.H.nrows() + qp.rows.slacks();
    let m = qp.rows.len();
    2 * (n + m) * n + m * n
}

/// The key a size error points at: the model's dimension.
fn size_key(spec: &Spec) -> Option<Span> {
    spec.spans
        .get("model.axes")
        .or_else(|| spec.spans.get("model.a"))
        .or_else(|| spec.spans.get("model"))
}

/// Refuses, before any matrix is formed, a spec whose lowering would exceed [`LOWERING_BYTES`] or
/// [`LOWERING_MACS`].
pub fn before_lowering(spec: &Spec) -> Result<(), Diagnostics> {
    let d = dims(spec);
    let (bytes, macs) = lowering(d);
    let shape = format!(
        "nx = {}, nu = {}, horizon N = {}: N·nx = {}",
        d.nx,
        d.nu,
        d.N,
        d.N * d.nx
    );
    let hint = "hint: fewer states or inputs, or a shorter horizon";
    if bytes > LOWERING_BYTES {
        return Err(Diagnostic::new(
            format!(
                "this controller is too large to build: lowering would form {} of matrices, above the limit of {}",
                size(bytes),
                size(LOWERING_BYTES)
            ),
            size_key(spec),
        )
        .label(shape)
        .note(hint)
        .into());
    }
    if macs > LOWERING_MACS {
        return Err(Diagnostic::new(
            format!(
                "this controller is too large to build: lowering would take {macs:.2e} multiply-adds, above the limit of {LOWERING_MACS:.0e}"
            ),
            size_key(spec),
        )
        .label(shape)
        .note(hint)
        .into());
    }
    Ok(())
}

/// The rows the constrained QP stacks for `spec`, counted from the spec alone: per slot (one slot per
/// stage, N of them), each state component with a finite bound and each input with a finite move
/// bound is one row, each row of a group one, and a soft one two (its halves); a soft state component
/// or soft group row adds one slack to the unknowns.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowCount {
    /// Rows of one slot.
    pub per_slot: usize,
    /// Slacks (unknowns besides the plan's N·nu).
    pub slacks: usize,
    /// The group with the most rows of a slot: its index and its rows (`None` without groups).
    pub largest_group: Option<(usize, usize)>,
}

impl RowCount {
    /// The count of `spec`'s constraints.
    pub fn of(spec: &Spec) -> Self {
        let c = &spec.mpc.constraints;
        // An absent side is an empty list (every entry free).
        let bounded = |lo: &[f64], hi: &[f64]| {
            (0..lo.len().max(hi.len()))
                .filter(|&i| {
                    lo.get(i).is_some_and(|v| v.is_finite())
                        || hi.get(i).is_some_and(|v| v.is_finite())
                })
                .count()
        };
        let states = bounded(&c.x_min, &c.x_max);
        let (mut per_slot, mut slacks) = match c.x_soft {
            Some(_) => (2 * states, states),
            None => (states, 0),
        };
        per_slot += bounded(&c.du_min, &c.du_max);
        let mut largest_group = None;
        for (i, g) in c.rows.iter().enumerate() {
            let rows = g.lower.len();
            let sides = if g.soft.is_some() { 2 * rows } else { rows };
            per_slot += sides;
            if g.soft.is_some() {
                slacks += rows;
            }
            if largest_group.is_none_or(|(_, r)| sides > r) {
                largest_group = Some((i, sides));
            }
        }
        RowCount {
            per_slot,
            slacks,
            largest_group,
        }
    }
}

/// Copies of the dense row matrix (m × (N·nu + slacks)) lowering and the analyses hold at once: the
/// lowered rows, the QP of one case, the structure's QP and the Riccati form's reproduction.
const ROW_COPIES: f64 = 4.0;

/// Refuses, before the rows are formed, a constrained spec whose row matrix and the structural analyses
/// over it (the normal matrix's pattern, the envelope, the Riccati form's reproduction of the rows)
/// would exceed [`LOWERING_BYTES`] or [`LOWERING_MACS`]: m = N·(rows of a slot) rows on
/// n = N·nu + slacks unknowns, ROW_COPIES·8·m·n bytes and m·(N·nu + 2)² + m·n·nx multiply-adds (each row's
/// outer product over its nonzeros, at most the plan's and one slack's). Located on the largest
/// `[[mpc.constraint]]` group, else on the state bounds.
pub fn before_constraints(spec: &Spec) -> Result<(), Diagnostics> {
    let c = RowCount::of(spec);
    if c.per_slot == 0 {
        return Ok(());
    }
    let d = dims(spec);
    let m = d.N * c.per_slot as f64;
    let n = d.N * d.nu + c.slacks as f64;
    let bytes = ROW_COPIES * 8.0 * m * n + 8.0 * 6.0 * n * n;
    let macs = m * (d.N * d.nu + 2.0).powi(2) + m * n * d.nx + n.powi(3) / 6.0;
    let over = if bytes > LOWERING_BYTES {
        format!(
            "its constraint rows would form {} of matrices, above the limit of {}",
            size(bytes),
            size(LOWERING_BYTES)
        )
    } else if macs > LOWERING_MACS {
        format!(
            "the analyses of its constraint rows would take {macs:.2e} multiply-adds, above the limit of {LOWERING_MACS:.0e}"
        )
    } else {
        return Ok(());
    };
    let (at, label) = match c.largest_group {
        Some((g, rows)) => (
            spec.spans
                .get(&format!("mpc.constraint[{g}].ax"))
                .or_else(|| spec.spans.get(&format!("mpc.constraint[{g}]"))),
            format!(
                "{rows} row sides a stage, the largest of {} at every one of the N = {} stages",
                c.per_slot, d.N
            ),
        ),
        None => (
            spec.spans
                .get("mpc.x_max")
                .or_else(|| spec.spans.get("mpc.x_min"))
                .or_else(|| spec.spans.get("mpc.du_max")),
            format!(
                "{} rows a stage at every one of the N = {} stages",
                c.per_slot, d.N
            ),
        ),
    };
    Err(Diagnostic::new(
        format!(
            "this controller is too large to build: {over} (m = {m:.0} rows on n = {n:.0} unknowns, {} of them slacks)",
            c.slacks
        ),
        at.or_else(|| spec.spans.get("mpc")),
    )
    .label(label)
    .note("hint: fewer rows (a soft row adds two rows and a slack), or a shorter `horizon`")
    .into())
}

/// The predicted cost of building a module of dimensions `d` that writes `tables` numbers and unrolls
/// `unrolled` multiply-adds.
pub fn predict(d: Dims, tables: usize, unrolled: usize) -> BuildCost {
    let (lowering_bytes, lowering_macs) = lowering(d);
    let source_bytes = BYTES_PER_TERM * (tables + unrolled) as f64;
    let table_mb = BYTES_PER_TERM * tables as f64 / MB;
    let m = unrolled as f64;
    BuildCost {
        lowering_bytes,
        lowering_macs,
        emitted_numbers: tables,
        emitted_unrolled: unrolled,
        source_bytes,
        rustc_seconds: 1.0 + 0.22 * table_mb + 4.6e-6 * m.powf(1.5),
        rustc_bytes: 120.0 * MB + 19.0 * table_mb * MB + 230.0 * MB * (m / 13_500.0).powf(1.18),
    }
}

/// Why a module of predicted cost `cost` is over [`RUSTC_BYTES`] or [`RUSTC_SECONDS`], if it is.
pub fn over(cost: &BuildCost) -> Option<String> {
    if cost.rustc_bytes > RUSTC_BYTES {
        Some(format!(
            "rustc would need about {} for the emitted module, above the limit of {}",
            size(cost.rustc_bytes),
            size(RUSTC_BYTES)
        ))
    } else if cost.rustc_seconds > RUSTC_SECONDS {
        Some(format!(
            "rustc would take about {:.0} s on the emitted module, above the limit of {RUSTC_SECONDS:.0} s",
            cost.rustc_seconds
        ))
    } else {
        None
    }
}

/// Refuses a module whose predicted rustc time or memory exceeds [`RUSTC_SECONDS`] or [`RUSTC_BYTES`];
/// `macs_filter` is the filter's share of the unrolled multiply-adds. `own` is the cost model's own
/// choice of emission and its cost when the spec forces another: if that one is within the budgets, the
/// error is the forced `codegen.emission`'s.
pub fn before_emission(
    spec: &Spec,
    cost: &BuildCost,
    macs_filter: usize,
    own: Option<&(Emission, BuildCost)>,
) -> Result<(), Diagnostics> {
    let Some(message) = over(cost) else {
        return Ok(());
    };
    let counts = format!(
        "{} numbers in tables and {} unrolled multiply-adds ({} of them the filter's), about {} of source",
        cost.emitted_numbers,
        cost.emitted_unrolled,
        macs_filter,
        size(cost.source_bytes)
    );
    let forced = spec.spans.get("codegen.emission");
    if let (Some((emission, own)), Some(at)) = (own, forced) {
        if over(own).is_none() {
            return Err(Diagnostic::new(
                format!("this controller is too large to build: {message}"),
                Some(at),
            )
            .label(format!("this emission makes {counts}"))
            .note(format!(
                "hint: the cost model's own choice, `emission = \"{}\"`, is predicted at about {:.0} s and {}: remove `emission` or write `emission = \"auto\"`",
                emission.name(),
                own.rustc_seconds,
                size(own.rustc_bytes)
            ))
            .into());
        }
    }
    Err(Diagnostic::new(
        format!("this controller is too large to build: {message}"),
        size_key(spec),
    )
    .label(counts)
    .note("hint: a `steady_state` filter unrolls far less than a time-varying one over a dense covariance; or fewer states, or a shorter horizon")
    .into())
}

/// "7.2 GB", "840 MB".
pub fn size(bytes: f64) -> String {
    if bytes >= 1e9 {
        format!("{:.1} GB", bytes / 1e9)
    } else if bytes >= 1e6 {
        format!("{:.0} MB", bytes / 1e6)
    } else {
        format!("{:.0} kB", bytes / 1e3)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The small linear plant (nx = 2, nu = 1) at `horizon`, with `extra` lines in `[mpc]`.
    fn spec(horizon: usize, extra: &str) -> Spec {
        mpc_spec::load(&format!(
            "[model]\ntype = \"linear\"\ndt = 0.1\na = [[1, 0.1], [0, 1]]\nb = [[0.005], [0.1]]\n\n[mpc]\nhorizon = {horizon}\niterations = 20\nmethod = \"ipm\"\nq = 1\nr = 0.1\nu_min = [-1]\nu_max = [1]\n{extra}"
        ))
        .unwrap()
    }

    fn group(rows: usize, soft: bool) -> String {
        let ax = vec!["[1, 0]"; rows].join(", ");
        let upper = vec!["1"; rows].join(", ");
        let soft = if soft { "soft = 1e3\n" } else { "" };
        format!("\n[[mpc.constraint]]\nax = [{ax}]\nupper = [{upper}]\n{soft}")
    }

    #[test]
    fn rows_are_counted_from_the_spec() {
        let s = spec(10, "x_max = [1, inf]\nx_soft = 1e3\ndu_max = [0.5]\n");
        assert_eq!(
            RowCount::of(&s),
            RowCount {
                per_slot: 3,
                slacks: 1,
                largest_group: None
            }
        );
        let s = spec(10, &format!("{}{}", group(2, false), group(3, true)));
        assert_eq!(
            RowCount::of(&s),
            RowCount {
                per_slot: 8,
                slacks: 3,
                largest_group: Some((1, 6))
            }
        );
    }

    #[test]
    fn a_row_matrix_past_the_budget_is_refused_on_its_group() {
        // 5,000 soft rows at N = 15: 150,000 row sides on 5,015 unknowns, 25 GB.
        let s = spec(15, &format!("{}{}", group(1, false), group(5000, true)));
        let d = before_constraints(&s).unwrap_err();
        let d = d.iter().next().unwrap();
        assert!(
            d.message.starts_with(
                "this controller is too large to build: its constraint rows would form"
            ),
            "{}",
            d.message
        );
        assert_eq!(d.span, s.spans.get("mpc.constraint[1].ax"));
        assert!(d.label.as_ref().unwrap().contains("N = 15"));
        // The same group hard is within the row budget (its sample is priced later).
        let s = spec(15, &group(5000, false));
        before_constraints(&s).unwrap();
        // And a spec without constraints costs nothing here.
        before_constraints(&spec(250, "")).unwrap();
    }

    #[test]
    fn the_region_hint_names_the_keys_and_their_values() {
        let s = spec(10, "x_max = [1, 1]\nx_min = [-1, -1]\n\n[mpc.region]\nsamples = 10000\nsequences = 100\nsteps = 1000\n");
        assert_eq!(
            crate::certify::sampling::sample_cases(&s, 2),
            (10_004, 100_000)
        );
        let hint = crate::certify::sampling::region_hint(&s, 2);
        for key in ["`samples` = 10000", "`sequences` = 100", "`steps` = 1000"] {
            assert!(hint.contains(key), "{hint}");
        }
        let hint = crate::certify::sampling::region_hint(&spec(10, "x_max = [1, 1]\n"), 2);
        assert!(hint.contains("`samples` = 50 (default)"), "{hint}");
    }
}
