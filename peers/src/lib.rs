//! Peers on the same QPs (issue 19): DAQP and the `mpc!`-generated solvers replay the condensed MPC
//! QPs that `mpcc dump-qp` wrote, solve against solve, on the host (`benches/peers.rs`,
//! `src/bin/accuracy.rs`) and on the emulated boards (`firmware/`).
//!
//! `no_std`: the same replay runs on the host and bare metal. The caller supplies the clock
//! ([`Timing`]); the C side allocates with `malloc` (the host's libc, or the firmware's bump
//! allocator).
#![no_std]
#![cfg_attr(mpc_neon, feature(stdarch_arm_neon_intrinsics))]
#![allow(clippy::excessive_precision, clippy::approx_constant)]

pub mod daqp;
pub mod problems {
    //! The dumped problems (`build.rs` writes them from `data/*.json`).
    #![allow(missing_docs, clippy::all)]
    include!(concat!(env!("OUT_DIR"), "/problems.rs"));
}

pub use daqp::Daqp;

/// The most steps a replay records.
pub const MAX_STEPS: usize = 200;

/// One dumped problem: the QP's data-free parts and the affine map of its data in DAQP's scalar
/// (infinite bounds ±1e30, DAQP's DAQP_INF), and the replayed steps in f64 (format `mpcc-qp/1`,
/// README.md). Matrices are row-major.
pub struct Data {
    /// The problem's name.
    pub name: &'static str,
    /// States, inputs, reference window length (N·nz), plan length (N·nu), unknowns, rows.
    pub nx: usize,
    /// Inputs.
    pub nu: usize,
    /// The reference window's length N·nz.
    pub nr: usize,
    /// The plan's length N·nu.
    pub np: usize,
    /// Unknowns z = (U, σ).
    pub n: usize,
    /// General rows.
    pub m: usize,
    /// Replayed steps.
    pub steps: usize,
    /// H (n × n).
    pub h: &'static [daqp::CFloat],
    /// F_x (np × nx).
    pub fx: &'static [daqp::CFloat],
    /// F_r (np × nr).
    pub fr: &'static [daqp::CFloat],
    /// F_u (np × nu).
    pub fu: &'static [daqp::CFloat],
    /// The slacks' linear weights (n − np).
    pub w: &'static [daqp::CFloat],
    /// Bounds on z (n).
    pub z_min: &'static [daqp::CFloat],
    /// Bounds on z (n).
    pub z_max: &'static [daqp::CFloat],
    /// The rows (m × n).
    pub a: &'static [daqp::CFloat],
    /// The rows' bounds before the data offset (m).
    pub lower: &'static [daqp::CFloat],
    /// The rows' bounds before the data offset (m).
    pub upper: &'static [daqp::CFloat],
    /// W_x (m × nx).
    pub wx: &'static [daqp::CFloat],
    /// W_u (m × nu).
    pub wu: &'static [daqp::CFloat],
    /// The reference window r (nr), the same every step.
    pub reference: &'static [f64],
    /// The states (steps × nx).
    pub x0: &'static [f64],
    /// The last inputs (steps × nu).
    pub u_last: &'static [f64],
    /// The exact solutions z* (steps × n).
    pub z_star: &'static [f64],
}

impl Data {
    /// Bytes of the QP's matrices and vectors in DAQP's scalar (what `Data` points DAQP at).
    pub fn daqp_data_bytes(&self) -> usize {
        let s = [
            self.h, self.fx, self.fr, self.fu, self.w, self.z_min, self.z_max, self.a, self.lower,
            self.upper, self.wx, self.wu,
        ];
        s.iter().map(|v| v.len()).sum::<usize>() * core::mem::size_of::<daqp::CFloat>()
    }
}

/// Times one solve.
pub trait Timing {
    /// Runs `solve` once and returns the ticks it took (and records whatever else, e.g. its stack).
    fn time(&mut self, solve: &mut dyn FnMut()) -> u64;
}

/// What a replay measured, per step.
pub struct Outcome {
    /// Ticks per solve.
    pub ticks: [u64; MAX_STEPS],
    /// |U − U*|∞ per solve.
    pub error: [f64; MAX_STEPS],
    /// Ticks of forming the QP's data per solve (DAQP: f and the rows' bounds from the state; 0 for
    /// ours, whose solve forms its own); included in `ticks`.
    pub form_ticks: [u64; MAX_STEPS],
    /// Iterations per solve (DAQP's active-set iterations; the generated active set's changes of the
    /// working set; 0 for the other generated solvers: fixed).
    pub iterations: [u32; MAX_STEPS],
    /// Solves that did not end optimal (DAQP's exit flag ≤ 0; the generated active set's fallbacks).
    pub failures: usize,
    /// Steps recorded.
    pub count: usize,
    /// Bytes of the solver's state between solves (ours: the generated `Mpc`; DAQP: its heap, set
    /// by the caller, which owns the allocator).
    pub state_bytes: usize,
}

impl Outcome {
    /// Nothing recorded yet.
    pub const fn new() -> Self {
        Outcome {
            ticks: [0; MAX_STEPS],
            error: [0.0; MAX_STEPS],
            form_ticks: [0; MAX_STEPS],
            iterations: [0; MAX_STEPS],
            failures: 0,
            count: 0,
            state_bytes: 0,
        }
    }

    /// Records one solve (beyond [`MAX_STEPS`] only the failure count).
    pub fn add(&mut self, ticks: u64, form_ticks: u64, error: f64, iterations: u32, ok: bool) {
        if !ok {
            self.failures += 1;
        }
        if self.count < MAX_STEPS {
            self.ticks[self.count] = ticks;
            self.error[self.count] = error;
            self.form_ticks[self.count] = form_ticks;
            self.iterations[self.count] = iterations;
            self.count += 1;
        }
    }

    /// (min, median, p99, max) of the ticks per solve.
    pub fn tick_quantiles(&self) -> [u64; 4] {
        let mut t = self.ticks;
        let t = &mut t[..self.count];
        t.sort_unstable();
        quantiles(t)
    }

    /// (min, median, p99, max) of the forming ticks.
    pub fn form_quantiles(&self) -> [u64; 4] {
        let mut t = self.form_ticks;
        let t = &mut t[..self.count];
        t.sort_unstable();
        quantiles(t)
    }

    /// (min, median, p99, max) of the iterations.
    pub fn iteration_quantiles(&self) -> [u32; 4] {
        let mut t = self.iterations;
        let t = &mut t[..self.count];
        t.sort_unstable();
        quantiles(t)
    }

    /// (median, max) of |U − U*|∞ (a NaN counts as the largest).
    pub fn error_median_max(&self) -> (f64, f64) {
        let mut e = self.error;
        let e = &mut e[..self.count];
        e.sort_unstable_by(|a, b| a.partial_cmp(b).unwrap_or(core::cmp::Ordering::Greater));
        if e.is_empty() {
            return (0.0, 0.0);
        }
        (e[e.len() / 2], e[e.len() - 1])
    }
}

impl Default for Outcome {
    fn default() -> Self {
        Self::new()
    }
}

/// Min, median (the upper one), 99th percentile (nearest rank) and max of a sorted slice.
fn quantiles<T: Copy + Default>(sorted: &[T]) -> [T; 4] {
    let n = sorted.len();
    if n == 0 {
        return [T::default(); 4];
    }
    let p99 = (99 * n).div_ceil(100).max(1) - 1;
    [sorted[0], sorted[n / 2], sorted[p99], sorted[n - 1]]
}

/// |x|, without `std`.
pub fn abs(x: f64) -> f64 {
    if x < 0.0 {
        -x
    } else {
        x
    }
}

/// |U − U*|∞ over the plan's np entries, NaN-propagating.
pub fn plan_error(plan: impl Iterator<Item = f64>, z_star: &[f64]) -> f64 {
    let mut e = 0.0_f64;
    for (u, s) in plan.zip(z_star) {
        let d = abs(u - s);
        if d > e || d.is_nan() {
            e = d;
        }
    }
    e
}

/// The replay of a generated controller of one problem module: `ours!(ours, ctrl, fixed)` defines
/// `pub fn ours(timing, outcome)` over the module `ctrl`; `status` instead of `fixed` also records
/// each solve's `SolverStatus` (the changes of the working set as iterations; a solve whose plan is
/// not its own, `Fallback` other than `Solved`, counted as not optimal). Each step solves from the
/// dumped state with the constant reference window, warm-started from the previous solve as in flight
/// (the controller's own warm start: shifted plan, the interior-point method's shifted iterate, or the
/// active set's previous working set). The state's conversion to the controller's scalar is outside
/// the timed span, as in the firmware template.
#[macro_export]
macro_rules! ours {
    (@record $mpc:ident, $ctrl:ident, fixed) => {
        (0u32, true)
    };
    (@record $mpc:ident, $ctrl:ident, status) => {{
        let status = *$mpc.solver_status();
        (
            status.iterations,
            status.fallback == $ctrl::Fallback::Solved,
        )
    }};
    ($name:ident, $ctrl:ident, $record:ident) => {
        /// Replays the steps through the generated controller.
        // `Real` is f32 or f64 by spec: the casts are conversions for one and no-ops for the other.
        #[allow(clippy::unnecessary_cast)]
        pub fn $name<T: $crate::Timing>(timing: &mut T, out: &mut $crate::Outcome) {
            use $ctrl::Real;
            const _: () = assert!($ctrl::NX == NZ, "the window is of states");

            /// One solve in a frame of its own, below the stack pointer at which the probe paints:
            /// inlined into the replay, the solve's locals would sit in the replay's frame, above it,
            /// uncounted.
            #[inline(never)]
            fn solve_once(
                mpc: &mut $ctrl::Mpc,
                x0: &[$ctrl::Real; $ctrl::NX],
                xref: &[[$ctrl::Real; $ctrl::NX]; $ctrl::N],
            ) {
                core::hint::black_box(mpc.solve(x0, xref));
            }

            let mut mpc = $ctrl::Mpc::new();
            out.state_bytes = core::mem::size_of::<$ctrl::Mpc>();
            let mut xref = [[0.0 as Real; $ctrl::NX]; $ctrl::N];
            for (k, row) in xref.iter_mut().enumerate() {
                for (j, v) in row.iter_mut().enumerate() {
                    *v = REFERENCE[k * NZ + j] as Real;
                }
            }
            for s in 0..STEPS {
                let x0: [Real; $ctrl::NX] = core::array::from_fn(|j| X0[s][j] as Real);
                let ticks = timing.time(&mut || {
                    solve_once(
                        &mut mpc,
                        core::hint::black_box(&x0),
                        core::hint::black_box(&xref),
                    );
                });
                let plan = mpc.plan();
                let error = $crate::plan_error(
                    plan.iter().flat_map(|u| u.iter().map(|&v| v as f64)),
                    &Z_STAR[s][..N * NU],
                );
                let (iterations, ok) = $crate::ours!(@record mpc, $ctrl, $record);
                out.add(ticks, 0, error, iterations, ok);
            }
        }
    };
}

/// The replay without a solver, in every firmware image: the same steps, states, last inputs,
/// reference and exact solutions read and the same bookkeeping, so that the code and data sizes of
/// an image with one solver minus one with neither (`firmware/run.sh --sizes`) are the solver's own.
/// `pub fn baseline(timing, outcome)` in each problem module.
#[macro_export]
macro_rules! baseline {
    () => {
        /// Reads every step's data as a replay does, solving nothing (the plan is zero).
        pub fn baseline<T: $crate::Timing>(timing: &mut T, out: &mut $crate::Outcome) {
            for s in 0..STEPS {
                let ticks = timing.time(&mut || {
                    core::hint::black_box((&X0[s], &U_LAST[s], &REFERENCE));
                });
                let error = $crate::plan_error(
                    core::iter::repeat_n(0.0, N * NU),
                    core::hint::black_box(&Z_STAR[s][..]),
                );
                out.add(ticks, 0, error, 0, true);
            }
        }
    };
}

/// Replays the steps of `data` through DAQP (set up once, hot-started from the previous working
/// set). `None` if its setup failed (out of memory or DAQP's flag). Each step is timed in two spans,
/// forming f and the bounds, then DAQP's update and solve; their sum is the solve's cost.
pub fn replay_daqp<T: Timing>(data: &Data, timing: &mut T, out: &mut Outcome) -> Option<()> {
    let mut d = Daqp::new(data)?;
    let r = daqp::convert::<{ daqp::MAX }>(data.reference);
    for s in 0..data.steps {
        let x0 = daqp::convert::<{ daqp::MAX }>(&data.x0[s * data.nx..(s + 1) * data.nx]);
        let ul = daqp::convert::<{ daqp::MAX }>(&data.u_last[s * data.nu..(s + 1) * data.nu]);
        let form = timing.time(&mut || {
            d.form(
                core::hint::black_box(&x0),
                core::hint::black_box(&r),
                core::hint::black_box(&ul),
            )
        });
        let mut flag = 0;
        let solve = timing.time(&mut || flag = d.solve());
        let z_star = &data.z_star[s * data.n..s * data.n + data.np];
        // CFloat is f32 or f64 by build: a conversion for one, a no-op for the other.
        #[allow(clippy::unnecessary_cast)]
        let error = plan_error(d.z()[..data.np].iter().map(|&v| v as f64), z_star);
        out.add(form + solve, form, error, d.iterations(), flag > 0);
    }
    Some(())
}
