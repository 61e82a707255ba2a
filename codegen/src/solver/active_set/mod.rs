//! A dual active-set method for the condensed inequality QP, specialised at build time: the f64
//! reference of the method's core (issue "A dual active-set method, specialised at build time").
//!
//! The QP is the one the interior-point method solves ([`InequalityQp`]):
//! min ½zᵀHz + fᵀz s.t. z_min ≤ z ≤ z_max, lower ≤ A·z ≤ upper, H ≻ 0. Soft rows need nothing of
//! their own: the MPC's QP keeps their slacks as variables with the L1 weight in f and the small
//! quadratic weight on H's diagonal (`ipm::mpc_qp`), so solving that QP exactly is solving the exact
//! penalty exactly. (DAQP's soft rows add a weight to their pivot instead, an L2 penalty whose
//! solutions differ; that is not done here.)
//!
//! The work is split as the generated controller will split it:
//! - **build time** ([`Prepared::new`]): the independent blocks, and per block the Cholesky factor R
//!   of H, the normalised rows M̂ = A·R⁻¹ (bounds as rows of R⁻¹), their Gram matrix G = M̂·M̂ᵀ, and the
//!   columns Z = R⁻¹·M̂ᵀ that map multipliers back to z ([`prepared`]);
//! - **per solve** ([`Prepared::offsets`]): the sides of the least-distance problem, affine in f and
//!   the bounds;
//! - **run time** ([`solve`]): the dual active-set iteration on each block (`iterate.rs`), the L·D·Lᵀ
//!   of the working set's block of G updated and downdated by rank one (`ldl.rs`), and
//!   z = z_free − Z_W·λ.
//!
//! Every tolerance is in [`Tolerances`], relative to quantities of the normalised problem (rows of
//! unit norm, so the pivots are relative to one and the slacks to the sides), so that a later f32
//! build can scale them to its unit roundoff in one place; the arithmetic is plain f64 loops that a
//! generic scalar can replace.
#![allow(non_snake_case)]

use super::constrained::InequalityQp;

pub mod emit;
pub mod exact;
pub mod method;
pub mod mpc;
pub mod prepared;
pub mod sampled;
pub mod slack_rows;
pub mod small_lp;

/// The method's title in the module's docs and diagnostics.
pub const TITLE: &str = "the dual active-set method";

/// The run-time kernel in f64: the reference, and what an f64 module runs.
#[allow(dead_code)]
pub(crate) mod kernel64 {
    use super::Tally;
    /// The kernel's scalar.
    pub(crate) type Real = f64;
    include!("kernel.rs");
}

/// The run-time kernel in f32: what an f32 module runs (the Cortex-M4F's), and its build-time check.
#[allow(dead_code)]
pub(crate) mod kernel32 {
    use super::Tally;
    /// The kernel's scalar.
    pub(crate) type Real = f32;
    include!("kernel.rs");
}

/// The kernel's source, which every emitted module includes.
pub const KERNEL_SOURCE: &str = include_str!("kernel.rs");

pub use prepared::{Block, Offsets, Prepared};

use mpc_spec::Scalar;
use nalgebra::DVector;
use std::fmt;

/// A constraint of the QP: a bound on one variable, or a row of A.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Row {
    /// `z_min[i] ≤ z[i] ≤ z_max[i]`.
    Bound(usize),
    /// `lower[r] ≤ (A·z)[r] ≤ upper[r]`.
    General(usize),
}

/// Which side of a constraint is active. A constraint is active at one side at most: its two sides
/// are distinct constraints of the method, with multipliers of opposite signs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Side {
    /// The lower bound holds with equality.
    Lower,
    /// The upper bound holds with equality.
    Upper,
}

/// An active side: a constraint and the side at which it holds with equality.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Active {
    /// The constraint.
    pub row: Row,
    /// Its side.
    pub side: Side,
}

/// A working set, in the order its sides entered the factor (the order a warm start adds them in).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WorkingSet(pub Vec<Active>);

impl WorkingSet {
    /// The sides `map` keeps, mapped: a warm start shifted by a stage maps each constraint to the one
    /// a stage earlier and drops those of the first stage.
    pub fn filter_map(&self, map: impl Fn(Active) -> Option<Active>) -> WorkingSet {
        WorkingSet(self.0.iter().filter_map(|a| map(*a)).collect())
    }

    /// The number of active sides.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether no side is active.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// How a solve ended.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Status {
    /// The KKT conditions hold within [`Tolerances`].
    Solved,
    /// The iterations ran out; z is the last dual-feasible iterate's (not primal feasible in general).
    IterationLimit,
    /// A violated side depends on the working set and no multiplier blocks the dual ray (the dual is
    /// unbounded), a row's sides cross, or a zero row of A excludes 0.
    Infeasible,
    /// The dual objective stopped increasing for [`Tolerances::cycle`] full steps, even after a
    /// refactorisation.
    Cycling,
    /// A non-finite offset or multiplier.
    NumericalFailure,
}

/// Why a QP cannot be prepared or its offsets formed.
#[derive(Clone, Debug, PartialEq)]
pub enum Error {
    /// H, A, f and the bounds disagree in size (or differ from the prepared QP's).
    Dimensions,
    /// The named data hold an infinite or NaN entry (a NaN for the bounds, which may be infinite).
    NonFinite(&'static str),
    /// A block of H is not positive definite (its Cholesky factorisation failed).
    NotPositiveDefinite {
        /// The block.
        block: usize,
    },
    /// A constraint without a finite side when prepared has one now.
    Pattern(Row),
    /// The bound of this variable lies outside the one its block's slack rows were proved within
    /// ([`Prepared::with_slack_rows`]).
    Bounds(usize),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Dimensions => write!(f, "the QP's dimensions are inconsistent"),
            Error::NonFinite(what) => write!(f, "{what} has a non-finite entry"),
            Error::NotPositiveDefinite { block } => write!(
                f,
                "block {block} of the Hessian is not positive definite: the dual active-set method needs H ≻ 0"
            ),
            Error::Pattern(row) => write!(
                f,
                "{row:?} has a finite side but had none when the QP was prepared"
            ),
            Error::Bounds(v) => write!(
                f,
                "the bounds of z[{v}] lie outside those its block's slack rows were proved within"
            ),
        }
    }
}

impl std::error::Error for Error {}

/// The tolerances of the iteration, in one place. They are relative to the normalised problem: the
/// rows of M̂ have unit norm, so a pivot of the factor is relative to one and a slack is compared with
/// its side. The values suit f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tolerances {
    /// A side is violated when its slack exceeds primal·(1 + |d|).
    pub primal: f64,
    /// A multiplier has the wrong sign beyond this.
    pub dual: f64,
    /// A pivot below this marks the new side dependent on the working set (DAQP's `sing_tol`).
    pub singular: f64,
    /// The factor is recomputed once, when the optimum is reached with a pivot below this (DAQP's
    /// `refactor_tol`): the downdates' round-off is dropped and the check repeated.
    pub refactor: f64,
    /// A pivot below this moves its side to the end of the factor, and at the optimum triggers one
    /// step of iterative refinement of λ (DAQP's `pivot_tol`).
    pub pivot: f64,
    /// A full step that raises the dual objective by less than progress·(1 + |objective|) makes no
    /// progress.
    pub progress: f64,
    /// Full steps in a row without progress before the factor is recomputed, and then before the
    /// solve ends [`Status::Cycling`].
    pub cycle: usize,
    /// A dependent side whose violation is at most infeasible·(1 + |d|), with no multiplier blocking,
    /// is taken for round-off at a degenerate vertex and set aside, not called infeasible.
    pub infeasible: f64,
}

impl Tolerances {
    /// The f64 values: DAQP's defaults but for the primal tolerance, tightened from 1e-6 (absolute)
    /// to 1e-11 relative, since the reference must agree with an exact solve to 1e-8.
    pub const F64: Tolerances = Tolerances {
        primal: 1e-11,
        dual: 1e-12,
        singular: 3.7e-11,
        refactor: 1e-9,
        pivot: 1e-6,
        progress: 1e-14,
        cycle: 10,
        infeasible: 1e-8,
    };
}

impl Tolerances {
    /// The f32 values: each f64 tolerance scaled toward f32's unit roundoff (2⁻²⁴ ≈ 6e-8). A slack is
    /// violated past 1e-5 of its side (about 170 roundoffs: the offsets are sums over a row), a pivot is
    /// singular below 1e-5 and small below 1e-3, and the progress test is at the roundoff.
    pub const F32: Tolerances = Tolerances {
        primal: 1e-5,
        dual: 1e-6,
        singular: 1e-5,
        refactor: 1e-4,
        pivot: 1e-3,
        progress: 1e-7,
        cycle: 10,
        infeasible: 1e-4,
    };

    /// The values for `scalar`.
    pub fn of(scalar: Scalar) -> Tolerances {
        match scalar {
            Scalar::F32 => Tolerances::F32,
            Scalar::F64 => Tolerances::F64,
        }
    }
}

/// The kernel's tolerances in its scalar.
macro_rules! kernel_tolerances {
    ($kernel:ident, $real:ty, $tol:expr) => {{
        let t: &Tolerances = $tol;
        $kernel::Tolerances {
            primal: t.primal as $real,
            dual: t.dual as $real,
            singular: t.singular as $real,
            refactor: t.refactor as $real,
            pivot: t.pivot as $real,
            progress: t.progress as $real,
            cycle: t.cycle,
            infeasible: t.infeasible as $real,
        }
    }};
}

impl Default for Tolerances {
    fn default() -> Self {
        Tolerances::F64
    }
}

/// Multiply-adds of a solve, by where they are spent (a division counts as one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Macs {
    /// The offsets d from f and the bounds: z_free (two triangular solves per block), then a dot
    /// product per constraint.
    pub offsets: usize,
    /// The slacks of the inactive rows, −G_{:,W}·λ: |W| per row scanned.
    pub scan: usize,
    /// The factor: the new row of L (a forward substitution), downdates, refactorisations.
    pub factor: usize,
    /// Solves with the factor: λ*, the singular directions, refinement.
    pub solve: usize,
    /// Steps of λ and the dual objective.
    pub step: usize,
    /// z = z_free − Z_W·λ.
    pub recover: usize,
    /// Rows visited by the scans (each row's slack cleared and its sides compared): not multiply-adds.
    pub rows: usize,
    /// Passes of the iteration: not multiply-adds.
    pub passes: usize,
}

impl Macs {
    /// All of them.
    pub fn total(&self) -> usize {
        self.offsets + self.scan + self.factor + self.solve + self.step + self.recover
    }

    /// The kernel's work, which a solve's budget caps: the multiply-adds and rows weighted by what each
    /// costs on the boards ([`WORK_KINDS`]), in tenths of a multiply-add of the factor's loops.
    pub fn work(&self) -> usize {
        WORK_KINDS
            .iter()
            .map(|(kind, _, weight)| self.of_kind(kind) * weight)
            .sum()
    }

    /// The count of one kind of [`WORK_KINDS`].
    fn of_kind(&self, kind: &str) -> usize {
        match kind {
            "offsets" => self.offsets,
            "scan" => self.scan,
            "factor" => self.factor,
            "solve" => self.solve,
            "step" => self.step,
            "recover" => self.recover,
            "rows" => self.rows,
            "pass" => self.passes,
            _ => 0,
        }
    }
}

/// Each kind of the kernel's work, as `kernel.rs` counts it (`tally.<kind>(n)`; `tally.pass()` one at a
/// time), with the constant of `kernel.rs` that weighs it and its value: [`Macs::work`] sums over this
/// table, and the emitted module's `Tally` is written from it, so that the budget the controller
/// enforces is the work the build sampled.
pub const WORK_KINDS: [(&str, &str, usize); 8] = {
    use kernel64::{WORK_MULTIPLY_ADD, WORK_PASS, WORK_ROW, WORK_SCAN, WORK_SWEEP};
    [
        ("offsets", "WORK_SWEEP", WORK_SWEEP),
        ("scan", "WORK_SCAN", WORK_SCAN),
        ("factor", "WORK_MULTIPLY_ADD", WORK_MULTIPLY_ADD),
        ("solve", "WORK_MULTIPLY_ADD", WORK_MULTIPLY_ADD),
        ("step", "WORK_MULTIPLY_ADD", WORK_MULTIPLY_ADD),
        ("recover", "WORK_SWEEP", WORK_SWEEP),
        ("rows", "WORK_ROW", WORK_ROW),
        ("pass", "WORK_PASS", WORK_PASS),
    ]
};

/// A solve's budget of work ([`Macs::work`]) without a cap.
pub const UNLIMITED_WORK: usize = usize::MAX;

/// The kernel's counter of multiply-adds (the emitted module's counts nothing): by kind, and per pass
/// of the iteration.
#[derive(Debug)]
pub(crate) struct Tally {
    macs: Macs,
    per_pass: Vec<usize>,
    mark: usize,
    budget: usize,
}

impl Tally {
    /// A tally whose solve stops changing the working set once its work exceeds `budget`.
    fn with_budget(budget: usize) -> Tally {
        Tally {
            macs: Macs::default(),
            per_pass: Vec::new(),
            mark: 0,
            budget,
        }
    }
    /// Whether the work so far exceeds the budget: the kernel then makes no more changes.
    fn exhausted(&self) -> bool {
        self.macs.work() > self.budget
    }
    fn offsets(&mut self, n: usize) {
        self.macs.offsets += n;
    }
    fn scan(&mut self, n: usize) {
        self.macs.scan += n;
    }
    fn factor(&mut self, n: usize) {
        self.macs.factor += n;
    }
    fn solve(&mut self, n: usize) {
        self.macs.solve += n;
    }
    fn step(&mut self, n: usize) {
        self.macs.step += n;
    }
    fn recover(&mut self, n: usize) {
        self.macs.recover += n;
    }
    fn rows(&mut self, n: usize) {
        self.macs.rows += n;
    }
    /// Ends a pass of the iteration: its multiply-adds since the last (offsets and recovery apart).
    fn pass(&mut self) {
        self.macs.passes += 1;
        let total = self.macs.scan + self.macs.factor + self.macs.solve + self.macs.step;
        if total > self.mark {
            self.per_pass.push(total - self.mark);
            self.mark = total;
        }
    }
}

/// The kernel's storage for the largest of `blocks`, in the kernel's scalar `T`.
struct Storage<T> {
    cap: usize,
    set: Vec<u32>,
    upper: Vec<bool>,
    real: [Vec<T>; 6],
    l: Vec<T>,
    mu: Vec<T>,
    active: Vec<bool>,
    excluded: Vec<bool>,
    lo: Vec<T>,
    hi: Vec<T>,
    z_free: Vec<T>,
}

impl<T: Copy + Default> Storage<T> {
    fn for_blocks(blocks: &[Block]) -> Storage<T> {
        let n = blocks.iter().map(Block::n).max().unwrap_or(0);
        let nc = blocks.iter().map(|b| b.rows.len()).max().unwrap_or(0);
        let cap = n + 1;
        let zero = T::default();
        Storage {
            cap,
            set: vec![0; cap],
            upper: vec![false; cap],
            real: std::array::from_fn(|_| vec![zero; cap]),
            l: vec![zero; cap * cap],
            mu: vec![zero; nc],
            active: vec![false; nc],
            excluded: vec![false; nc],
            lo: vec![zero; nc],
            hi: vec![zero; nc],
            z_free: vec![zero; n],
        }
    }
}

/// The kernel's view of a [`Storage`].
macro_rules! work {
    ($kernel:ident, $storage:expr) => {{
        let s = $storage;
        let [lambda, star, y, scaled, tmp, d] = &mut s.real;
        $kernel::Work {
            set: &mut s.set,
            upper: &mut s.upper,
            lambda,
            star,
            y,
            scaled,
            tmp,
            l: &mut s.l,
            d,
            mu: &mut s.mu,
            active: &mut s.active,
            excluded: &mut s.excluded,
            lo: &mut s.lo,
            hi: &mut s.hi,
            z_free: &mut s.z_free,
            cap: s.cap,
        }
    }};
}

/// What a solve returns.
#[derive(Clone, Debug)]
pub struct Outcome {
    /// How it ended; the worst of the blocks' (in the order of [`Status`]'s severity: numerical
    /// failure, infeasible, cycling, iteration limit, solved).
    pub status: Status,
    /// The solution (the last iterate where the solve did not end [`Status::Solved`]).
    pub z: DVector<f64>,
    /// The final working set, block by block; the warm start of the next solve.
    pub working_set: WorkingSet,
    /// The multipliers of the working set's sides in the QP's own scale, aligned with it: y ≥ 0 with
    /// H·z + f + Σ_upper y·a − Σ_lower y·a = 0 (a the side's row, e_i for a bound).
    pub multipliers: Vec<f64>,
    /// Changes of the working set (additions and removals), over all blocks. A warm start from the
    /// optimal working set takes none.
    pub iterations: usize,
    /// The same per block.
    pub block_iterations: Vec<usize>,
    /// The multiply-adds spent, offsets and recovery included.
    pub macs: Macs,
    /// The multiply-adds of each pass of the iteration (λ*, then a removal, or the scan and an
    /// addition, or the final check), block after block; a pass that changes the working set is one
    /// iteration.
    pub per_pass: Vec<usize>,
}

/// Solves the prepared QP with the offsets of its data ([`Prepared::offsets`]) from `start` (the
/// previous solve's working set, or `None` for a cold start), with at most `max_iterations` changes of
/// the working set over all blocks; [`Tolerances::F64`].
///
/// **The warm start's rule.** The sides of `start` are added to the factor in their order, each with
/// multiplier ±1 (its side's sign, so the start is dual feasible); a side is dropped when its
/// constraint is not among the prepared ones (no finite side when prepared) or has no finite bound at
/// that side now, when its constraint is already in the set (at either side), or when it depends on
/// the sides before it (its pivot below [`Tolerances::singular`], or more sides than the block has
/// variables). The start need not be primal feasible: the dual method only needs it independent. Its
/// sides whose multipliers at the constrained stationary point have the wrong sign are then removed by
/// the ordinary blocking steps, which count as iterations.
pub fn solve(
    prepared: &Prepared,
    offsets: &Offsets,
    start: Option<&WorkingSet>,
    max_iterations: usize,
) -> Outcome {
    solve_with(prepared, offsets, start, max_iterations, &Tolerances::F64)
}

/// One solve by the kernel of module `$kernel` in its scalar `$real`: the offsets rounded to it, the
/// blocks' tables in it (`Block::$tables`), and what it ended with, made, and z in f64.
macro_rules! kernel_solve {
    ($kernel:ident, $real:ty, $tables:ident, $prepared:expr, $offsets:expr, $tol:expr, $warm:expr, $warm_len:expr, $max:expr, $tally:expr, $outcome:expr) => {{
        let prepared: &Prepared = $prepared;
        let offsets: &Offsets = $offsets;
        let outcome: &mut Outcome = &mut $outcome;
        let blocks: Vec<$kernel::Block> = prepared.blocks.iter().map(Block::$tables).collect();
        let mut storage = Storage::<$real>::for_blocks(&prepared.blocks);
        let mut work = work!($kernel, &mut storage);
        let round = |v: &[f64]| -> Vec<$real> { v.iter().map(|x| *x as $real).collect() };
        let (f, lower, upper) = (
            round(&offsets.f),
            round(&offsets.lower),
            round(&offsets.upper),
        );
        let mut z: Vec<$real> = vec![<$real>::NAN; prepared.n];
        let (ended, iterations) = $kernel::solve(
            &blocks,
            &f,
            &lower,
            &upper,
            &mut work,
            &mut $warm,
            &mut $warm_len,
            $max,
            &kernel_tolerances!($kernel, $real, $tol),
            &mut $tally,
            &mut z,
            |b, w, k, changes| {
                let block = &prepared.blocks[b];
                outcome.block_iterations[b] = changes;
                for i in 0..k {
                    let c = w.set[i] as usize;
                    let side = if w.upper[i] { Side::Upper } else { Side::Lower };
                    let sign = if w.upper[i] { 1.0 } else { -1.0 };
                    outcome.working_set.0.push(Active {
                        row: block.rows[c],
                        side,
                    });
                    outcome
                        .multipliers
                        .push(sign * f64::from(w.lambda[i]) / block.scale[c]);
                }
            },
        );
        let ended = match ended {
            $kernel::Ended::Solved => Status::Solved,
            $kernel::Ended::IterationLimit => Status::IterationLimit,
            $kernel::Ended::Cycling => Status::Cycling,
            $kernel::Ended::Infeasible => Status::Infeasible,
            $kernel::Ended::NumericalFailure => Status::NumericalFailure,
        };
        (
            ended,
            iterations,
            z.iter().map(|v| f64::from(*v)).collect::<Vec<f64>>(),
        )
    }};
}

/// [`solve`] with the given tolerances, in f64: the run-time kernel (`kernel.rs`, the code the emitted
/// module runs), with its multiply-adds counted.
pub fn solve_with(
    prepared: &Prepared,
    offsets: &Offsets,
    start: Option<&WorkingSet>,
    max_iterations: usize,
    tol: &Tolerances,
) -> Outcome {
    solve_in(prepared, offsets, start, max_iterations, tol, Scalar::F64)
}

/// [`solve_with`] by the kernel in `scalar`: f32 rounds the offsets and the tables to f32 and runs the
/// f32 kernel, as an f32 module does.
pub fn solve_in(
    prepared: &Prepared,
    offsets: &Offsets,
    start: Option<&WorkingSet>,
    max_iterations: usize,
    tol: &Tolerances,
    scalar: Scalar,
) -> Outcome {
    solve_within(
        prepared,
        offsets,
        start,
        (max_iterations, UNLIMITED_WORK),
        tol,
        scalar,
    )
}

/// [`solve_in`] with a budget of work besides the changes, `(max_iterations, budget)`: no change of
/// the working set is made once the solve's work ([`Macs::work`]) exceeds `budget`, and the solve
/// then ends [`Status::IterationLimit`] as it does when the changes run out.
pub fn solve_within(
    prepared: &Prepared,
    offsets: &Offsets,
    start: Option<&WorkingSet>,
    (max_iterations, budget): (usize, usize),
    tol: &Tolerances,
    scalar: Scalar,
) -> Outcome {
    let nblocks = prepared.blocks.len();
    let (n, m) = (prepared.n, prepared.m);
    let mut outcome = Outcome {
        status: Status::Solved,
        z: DVector::from_element(n, f64::NAN),
        working_set: WorkingSet::default(),
        multipliers: Vec::new(),
        iterations: 0,
        block_iterations: vec![0; nblocks],
        macs: Macs::default(),
        per_pass: Vec::new(),
    };
    let shapes_agree =
        offsets.f.len() == n && offsets.lower.len() == n + m && offsets.upper.len() == n + m;
    if !shapes_agree {
        outcome.status = Status::NumericalFailure;
        return outcome;
    }
    if offsets.empty_zero_row.is_some() {
        outcome.status = Status::Infeasible;
        return outcome;
    }
    // The warm start, split by block, in the kernel's code: twice the constraint, plus one at an upper
    // side.
    let mut warm = vec![0u32; prepared.warm_len()];
    let mut warm_len = vec![0u32; nblocks];
    for a in start.map(|s| s.0.as_slice()).unwrap_or(&[]) {
        let index = match a.row {
            Row::Bound(i) if i < n => i,
            Row::General(r) if r < m => n + r,
            _ => continue,
        };
        if let Some((b, c)) = prepared.place[index] {
            let block = &prepared.blocks[b];
            let len = warm_len[b] as usize;
            if len <= block.n() {
                warm[block.packed.warm_at + len] =
                    (2 * c + usize::from(a.side == Side::Upper)) as u32;
                warm_len[b] += 1;
            }
        }
    }
    let mut tally = Tally::with_budget(budget);
    let (ended, iterations, z) = match scalar {
        Scalar::F64 => kernel_solve!(
            kernel64,
            f64,
            kernel,
            prepared,
            offsets,
            tol,
            warm,
            warm_len,
            max_iterations,
            tally,
            outcome
        ),
        Scalar::F32 => kernel_solve!(
            kernel32,
            f32,
            kernel32,
            prepared,
            offsets,
            tol,
            warm,
            warm_len,
            max_iterations,
            tally,
            outcome
        ),
    };
    outcome.status = ended;
    outcome.z = DVector::from_vec(z);
    outcome.iterations = iterations;
    outcome.macs = tally.macs;
    outcome.per_pass = tally.per_pass;
    outcome
}

/// Prepares `qp`, forms its offsets and solves it: for tests and one-off solves (a controller prepares
/// once and forms offsets per step).
pub fn solve_qp(
    qp: &InequalityQp,
    start: Option<&WorkingSet>,
    max_iterations: usize,
) -> Result<Outcome, Error> {
    let prepared = Prepared::new(qp)?;
    let offsets = prepared.offsets(qp)?;
    Ok(solve(&prepared, &offsets, start, max_iterations))
}
