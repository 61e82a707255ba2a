//! The runs: each controller on the flight, on the flight with the gust, on the flight in wind,
//! and on the step; and the geofence scenario, the flight with the constrained controller of
//! `specs/paper-geofence.toml`.

use std::time::Instant;

use codegen::lower::Qp;
use flight_sim::metrics::{StepMetrics, StepResponse, Table2, Tracking};
use flight_sim::{
    fly_with, Controller, Disturbance, DisturbanceModel, Dryden, NoiseConfig, Pid, PidController,
    Reference, Scenario, Step, Trajectory, Wind, DT,
};
use generated_examples::geofence::{Solve, Tally};
use nalgebra::DVector;

flight_sim::mpc_controller!(
    /// `specs/paper.toml`: FGM with step 1/L, the project's tuned controller.
    pub struct PaperMpc(generated_examples::paper)
);
flight_sim::mpc_controller!(
    /// `specs/paper-faithful.toml`: the paper's Algorithm 1 (projected gradient, α = 0.04).
    pub struct FaithfulMpc(generated_examples::paper_faithful)
);
flight_sim::mpc_controller!(
    /// `specs/paper-initial.toml`: Table 1's initial parameters (N = 5, 100 iterations, α = 0.01).
    pub struct InitialMpc(generated_examples::paper_initial)
);
flight_sim::mpc_controller!(
    /// `specs/paper-offset-free.toml`: `paper.toml` with a disturbance estimate (offset-free MPC).
    pub struct OffsetFreeMpc(generated_examples::paper_offset_free),
    disturbance
);
flight_sim::mpc_controller!(
    /// `specs/paper-geofence.toml`: `paper-limits.toml` (the speed limit and the floor) plus the wall
    /// y ≤ 8 m, all soft, on the dual active-set method (`auto`'s choice).
    pub struct GeofenceMpc(generated_examples::paper_geofence)
);
flight_sim::generated_kalman!(
    /// The generated filter of `specs/paper.toml`, feeding the PID.
    pub struct PaperKalman(generated_examples::paper)
);

/// The controllers compared, in report order.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, clap::ValueEnum)]
pub enum Kind {
    /// The MPC generated from `specs/paper.toml` (FGM, step 1/L).
    #[value(name = "mpc")]
    Mpc,
    /// The offset-free MPC generated from `specs/paper-offset-free.toml` (`paper.toml` with a
    /// disturbance-estimating filter).
    #[value(name = "mpc-offset-free")]
    MpcOffsetFree,
    /// The MPC generated from `specs/paper-faithful.toml` (Algorithm 1, α = 0.04).
    #[value(name = "mpc-faithful")]
    MpcFaithful,
    /// The MPC generated from `specs/paper-initial.toml` (Table 1's initial parameters).
    #[value(name = "mpc-initial")]
    MpcInitial,
    /// The PID of Section 3.1.2 on the generated filter.
    #[value(name = "pid")]
    Pid,
}

impl Kind {
    /// Every controller, in report order.
    pub const ALL: [Kind; 5] = [
        Kind::Mpc,
        Kind::MpcOffsetFree,
        Kind::MpcFaithful,
        Kind::MpcInitial,
        Kind::Pid,
    ];

    /// Key in `summary.json` and file names.
    pub fn key(self) -> &'static str {
        match self {
            Kind::Mpc => "mpc",
            Kind::MpcOffsetFree => "mpc-offset-free",
            Kind::MpcFaithful => "mpc-faithful",
            Kind::MpcInitial => "mpc-initial",
            Kind::Pid => "pid",
        }
    }

    /// What it is, for tables and legends.
    pub fn label(self) -> &'static str {
        match self {
            Kind::Mpc => "MPC (paper.toml, FGM 1/L)",
            Kind::MpcOffsetFree => {
                "offset-free MPC (paper-offset-free.toml: paper.toml + disturbance estimate)"
            }
            Kind::MpcFaithful => "MPC (paper-faithful.toml, Alg. 1 α=0.04)",
            Kind::MpcInitial => "MPC (paper-initial.toml, Table 1: N=5, α=0.01)",
            Kind::Pid => "PID (kp 34.2, ki 8, kd 23.4)",
        }
    }

    /// The spec the controller was generated from, for the oracle.
    fn spec(self) -> Option<&'static str> {
        match self {
            Kind::Mpc => Some(include_str!("../../../../specs/paper.toml")),
            Kind::MpcOffsetFree => Some(include_str!("../../../../specs/paper-offset-free.toml")),
            Kind::MpcFaithful => Some(include_str!("../../../../specs/paper-faithful.toml")),
            Kind::MpcInitial => Some(include_str!("../../../../specs/paper-initial.toml")),
            Kind::Pid => None,
        }
    }
}

/// The three scenarios of the paper, and the wind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Test {
    /// The tracking flight (Table 2).
    Flight,
    /// The same flight with the gust of Section 3.2.4.
    Gust,
    /// The same flight in a constant wind with Dryden-like gusts (`flight_sim::Wind`).
    Wind,
    /// 1 m steps from hover (Table 3).
    Step,
}

/// What every run shares.
#[derive(Clone, Copy, Debug)]
pub struct Settings {
    pub noise: NoiseConfig,
    pub duration: f64,
    pub step_duration: f64,
    pub step_noise: bool,
    pub oracle_stride: usize,
    pub pid_derivative: flight_sim::Derivative,
    /// The wind of [`Test::Wind`].
    pub wind: Dryden,
}

/// One cycle kept for plots and CSV.
#[derive(Clone, Copy, Debug, Default)]
pub struct Row {
    pub t: f64,
    pub reference: [f64; 6],
    pub state: [f64; 6],
    pub estimate: [f64; 6],
    pub command: [f64; 3],
    pub solve_us: f64,
    /// The acceleration added to the plant (gust or wind), m/s².
    pub disturbance: [f64; 3],
    /// The controller's disturbance estimate (offset-free MPC only), m/s².
    pub disturbance_estimate: Option<[f64; 3]>,
}

/// Distance of the generated command from the exact optimum of the same QP, over the cycles
/// compared.
#[derive(Clone, Copy, Debug, Default)]
pub struct QpGap {
    /// Number of cycles compared.
    pub count: usize,
    /// Sum and max of |u₀ − u₀*|₂, m/s².
    pub u_dist_sum: f64,
    pub u_dist_max: f64,
    /// Sum of J(U) − J(U*), the cost the fixed iterations leave on the table.
    pub cost_gap_sum: f64,
    /// Sum of |u₀*|₂, to put the distance in proportion.
    pub u_star_sum: f64,
}

/// The outcome of one run.
#[derive(Debug)]
pub struct Run {
    pub kind: Kind,
    pub test: Test,
    pub seed: u64,
    pub table2: Table2,
    pub step: [StepMetrics; 3],
    /// Tracking error per cycle and axis (for the gust and wind figures).
    pub error: Vec<[f64; 3]>,
    pub solve_us_mean: f64,
    pub solve_us_median: f64,
    pub solve_us_p99: f64,
    pub solve_us_max: f64,
    pub gap: Option<QpGap>,
    /// Per-cycle rows, kept for the first seed only.
    pub rows: Vec<Row>,
    /// Measurements the controller's filter rejected (gated, stuck, non-finite) over the run.
    pub rejected: usize,
}

/// The exact solution of an MPC's own QP, from the generic runtime solver of `codegen`.
pub struct Oracle {
    qp: Qp,
    mpc: codegen::oracle::Mpc,
}

impl Oracle {
    /// The oracle of the controller generated from `spec`.
    pub fn new(spec: &str) -> Result<Self, String> {
        let spec = mpc_spec::load(spec).map_err(|d| d.to_string())?;
        let problem = codegen::lower(&spec).map_err(|d| d.to_string())?;
        let mpc = codegen::oracle::Mpc::new(&problem);
        Ok(Self {
            qp: problem.qp,
            mpc,
        })
    }

    /// Compares the plan `plan` (N·nu, stacked by step) solved from `x0`, the disturbance estimate
    /// `d` (empty without one) and `xref` with the exact optimum: returns (|u₀ − u₀*|₂,
    /// J(U) − J(U*), |u₀*|₂).
    pub fn compare(
        &self,
        x0: &[f64],
        d: &[f64],
        xref: &[Vec<f64>],
        plan: &[f64],
    ) -> (f64, f64, f64) {
        let x0 = DVector::from_column_slice(x0);
        let xref: Vec<DVector<f64>> = xref.iter().map(|r| DVector::from_column_slice(r)).collect();
        let mut f = self.mpc.linear_term(&x0, &xref);
        if !d.is_empty() {
            f += &self.qp.Fd * DVector::from_column_slice(d);
        }
        let exact = codegen::oracle::exact_solution(&self.qp, &f, 1e-9, 20_000);
        let u = DVector::from_column_slice(plan);
        let cost = |v: &DVector<f64>| 0.5 * v.dot(&(&self.qp.H * v)) + f.dot(v);
        let nu = self.qp.u_min.len();
        let du = (u.rows(0, nu) - exact.rows(0, nu)).norm();
        (du, cost(&u) - cost(&exact), exact.rows(0, nu).norm())
    }
}

/// A controller as the runs see it: it may expose its plan for the oracle.
pub trait Flown: Controller {
    /// For an MPC, what its last solve (at cycle `k`) saw and gave, in `f64`: the estimate it
    /// started from, the disturbance estimate it used (empty without one), the reference window
    /// (rounded to the controller's scalar, as it saw it) and the plan (N·nu, stacked by step).
    fn last_solve<R: Reference>(&self, _k: usize, _reference: &R) -> Option<LastSolve> {
        None
    }

    /// The disturbance estimate the last command was computed with, m/s² (offset-free only).
    fn disturbance_estimate(&self) -> Option<[f64; 3]> {
        None
    }
}

/// See [`Flown::last_solve`].
pub type LastSolve = (Vec<f64>, Vec<f64>, Vec<Vec<f64>>, Vec<f64>);

impl Flown for PidController<PaperKalman> {}

macro_rules! flown_mpc {
    (@disturbance $c:ident) => {
        Vec::new()
    };
    (@disturbance $c:ident, $disturbance:ident) => {
        $c.last_disturbance().iter().map(|v| f64::from(*v)).collect()
    };
    ($name:ident, $($m:ident)::+ $(, $disturbance:ident)?) => {
        impl Flown for $name {
            fn last_solve<R: Reference>(&self, k: usize, reference: &R) -> Option<LastSolve> {
                let x0 = self.last_x0().iter().map(|v| f64::from(*v)).collect();
                let d: Vec<f64> = flown_mpc!(@disturbance self $(, $disturbance)?);
                let window = reference.window::<$($m)::+::Real, { $($m)::+::N }>(k);
                let xref = window.iter().map(|r| r.iter().map(|v| f64::from(*v)).collect()).collect();
                let plan = self.mpc().plan().iter().flatten().map(|v| f64::from(*v)).collect();
                Some((x0, d, xref, plan))
            }
            $(fn disturbance_estimate(&self) -> Option<[f64; 3]> {
                let $disturbance = flight_sim::cast(self.last_disturbance());
                Some($disturbance)
            })?
        }
    };
}
flown_mpc!(PaperMpc, generated_examples::paper);
flown_mpc!(
    OffsetFreeMpc,
    generated_examples::paper_offset_free,
    disturbance
);
flown_mpc!(FaithfulMpc, generated_examples::paper_faithful);
flown_mpc!(InitialMpc, generated_examples::paper_initial);

/// Times each control step (filter update, control law, filter predict) with the wall clock.
struct Timed<C> {
    inner: C,
    last_ns: u128,
}

impl<C: Controller> Controller for Timed<C> {
    fn step<R: Reference>(&mut self, k: usize, z: &[f64; 3], reference: &R) -> [f64; 3] {
        let start = Instant::now();
        let u = self.inner.step(k, z, reference);
        self.last_ns = start.elapsed().as_nanos();
        u
    }
    fn estimate(&self) -> [f64; 6] {
        self.inner.estimate()
    }
    fn rejected_measurements(&self) -> usize {
        self.inner.rejected_measurements()
    }
}

/// Runs `kind` on `test` with `seed`, keeping per-cycle rows if `keep_rows`.
pub fn run(kind: Kind, test: Test, seed: u64, settings: &Settings, keep_rows: bool) -> Run {
    let oracle = match (test, settings.oracle_stride, kind.spec()) {
        (Test::Flight, s, Some(spec)) if s > 0 => {
            Some(Oracle::new(spec).expect("the shipped spec compiles, as the macro proved"))
        }
        _ => None,
    };
    let trajectory = Trajectory::paper();
    let step = Step::paper();
    let (cycles, noise, disturbance) = match test {
        Test::Flight | Test::Wind => (
            Scenario::cycles_for(settings.duration),
            settings.noise,
            Disturbance::NONE,
        ),
        Test::Gust => (
            Scenario::cycles_for(settings.duration),
            settings.noise,
            Disturbance::GUST,
        ),
        Test::Step => (
            Scenario::cycles_for(step.at + settings.step_duration),
            if settings.step_noise {
                settings.noise
            } else {
                NoiseConfig::NONE
            },
            Disturbance::NONE,
        ),
    };
    let scenario = Scenario {
        seed,
        cycles,
        noise,
        disturbance,
    };
    let x0 = match test {
        Test::Step => step.state(0),
        _ => trajectory.start(),
    };
    // The wind's own ChaCha8 stream of the seed: every controller meets the same wind.
    let mut wind = Wind::new(
        seed,
        if test == Test::Wind {
            settings.wind.config()
        } else {
            flight_sim::WindConfig::NONE
        },
    );
    let ctx = Context {
        kind,
        test,
        seed,
        keep_rows,
        oracle: oracle.as_ref(),
        stride: settings.oracle_stride,
    };
    let w = &mut wind;
    match (kind, test) {
        (Kind::Mpc, Test::Step) => ctx.go(PaperMpc::new(&x0), &step, &scenario, w),
        (Kind::Mpc, _) => ctx.go(PaperMpc::new(&x0), &trajectory, &scenario, w),
        (Kind::MpcOffsetFree, Test::Step) => ctx.go(OffsetFreeMpc::new(&x0), &step, &scenario, w),
        (Kind::MpcOffsetFree, _) => ctx.go(OffsetFreeMpc::new(&x0), &trajectory, &scenario, w),
        (Kind::MpcFaithful, Test::Step) => ctx.go(FaithfulMpc::new(&x0), &step, &scenario, w),
        (Kind::MpcFaithful, _) => ctx.go(FaithfulMpc::new(&x0), &trajectory, &scenario, w),
        (Kind::MpcInitial, Test::Step) => ctx.go(InitialMpc::new(&x0), &step, &scenario, w),
        (Kind::MpcInitial, _) => ctx.go(InitialMpc::new(&x0), &trajectory, &scenario, w),
        (Kind::Pid, Test::Step) => ctx.go(pid(&x0, settings), &step, &scenario, w),
        (Kind::Pid, _) => ctx.go(pid(&x0, settings), &trajectory, &scenario, w),
    }
}

fn pid(x0: &[f64; 6], settings: &Settings) -> PidController<PaperKalman> {
    PidController::new(Pid::paper(), PaperKalman::new(x0)).with_derivative(settings.pid_derivative)
}

struct Context<'a> {
    kind: Kind,
    test: Test,
    seed: u64,
    keep_rows: bool,
    oracle: Option<&'a Oracle>,
    stride: usize,
}

impl Context<'_> {
    fn go<C: Flown, R: Reference>(
        &self,
        controller: C,
        reference: &R,
        scenario: &Scenario,
        extra: &mut dyn DisturbanceModel,
    ) -> Run {
        let mut timed = Timed {
            inner: controller,
            last_ns: 0,
        };
        let mut tracking = Tracking::new(DT);
        let origin = reference.state(0);
        let at = Step::paper().at;
        let mut steps: [StepResponse; 3] =
            core::array::from_fn(|i| StepResponse::new(origin[i], Step::paper().size[i], at));
        let mut error = Vec::with_capacity(scenario.cycles);
        let mut rows = Vec::with_capacity(if self.keep_rows { scenario.cycles } else { 0 });
        let mut times_ns: Vec<u128> = Vec::with_capacity(scenario.cycles);
        let mut gap = self.oracle.map(|_| QpGap::default());
        fly_with(&mut timed, reference, scenario, extra, |s, c| {
            let e = s.error();
            tracking.push(s.t, &e, &s.command);
            error.push(e);
            for (i, r) in steps.iter_mut().enumerate() {
                r.push(s.t, s.state[i]);
            }
            times_ns.push(c.last_ns);
            if let (Some(oracle), Some(g)) = (self.oracle, gap.as_mut()) {
                if s.k % self.stride == 0 {
                    if let Some((x0, d, xref, plan)) = c.inner.last_solve(s.k, reference) {
                        let (du, dj, us) = oracle.compare(&x0, &d, &xref, &plan);
                        g.count += 1;
                        g.u_dist_sum += du;
                        g.u_dist_max = g.u_dist_max.max(du);
                        g.cost_gap_sum += dj;
                        g.u_star_sum += us;
                    }
                }
            }
            if self.keep_rows {
                rows.push(Row {
                    t: s.t,
                    reference: s.reference,
                    state: s.state,
                    estimate: c.estimate(),
                    command: s.command,
                    solve_us: c.last_ns as f64 / 1e3,
                    disturbance: s.disturbance,
                    disturbance_estimate: c.inner.disturbance_estimate(),
                });
            }
        });
        let n = times_ns.len().max(1) as f64;
        let sum_ns: u128 = times_ns.iter().sum();
        times_ns.sort_unstable();
        let median_ns = times_ns.get(times_ns.len() / 2).copied().unwrap_or(0);
        let p99_ns = times_ns
            .get((times_ns.len() * 99) / 100)
            .copied()
            .unwrap_or(0);
        let max_ns = times_ns.last().copied().unwrap_or(0);
        Run {
            kind: self.kind,
            test: self.test,
            seed: self.seed,
            table2: tracking.finish(),
            step: core::array::from_fn(|i| steps[i].finish()),
            error,
            solve_us_mean: sum_ns as f64 / n / 1e3,
            solve_us_median: median_ns as f64 / 1e3,
            solve_us_p99: p99_ns as f64 / 1e3,
            solve_us_max: max_ns as f64 / 1e3,
            gap,
            rows,
            rejected: timed.rejected_measurements(),
        }
    }
}

/// The outcome of the geofence scenario for one seed.
#[derive(Debug)]
pub struct GeofenceRun {
    /// The constraints along the flight: the true state's, the estimate's and the plan's violations,
    /// and what the solver reported.
    pub tally: Tally,
    pub table2: Table2,
    pub solve_us_mean: f64,
    pub solve_us_max: f64,
    /// Per-cycle rows, kept for the first seed only.
    pub rows: Vec<Row>,
    pub rejected: usize,
}

/// Flies the reference flight with the geofence controller: the flight of [`Test::Flight`] (same
/// duration, noise and seed, no disturbance), the controller wired as the other MPCs are, its filter
/// its own (the same parameters as `paper.toml`'s). Keeps per-cycle rows if `keep_rows`.
pub fn geofence(seed: u64, settings: &Settings, keep_rows: bool) -> GeofenceRun {
    let trajectory = Trajectory::paper();
    let scenario = Scenario {
        seed,
        cycles: Scenario::cycles_for(settings.duration),
        noise: settings.noise,
        disturbance: Disturbance::NONE,
    };
    let mut timed = Timed {
        inner: GeofenceMpc::new(&trajectory.start()),
        last_ns: 0,
    };
    let mut tally = Tally::default();
    let mut tracking = Tracking::new(DT);
    let mut rows = Vec::with_capacity(if keep_rows { scenario.cycles } else { 0 });
    let (mut sum_ns, mut max_ns) = (0u128, 0u128);
    let mut none = Disturbance::NONE;
    fly_with(&mut timed, &trajectory, &scenario, &mut none, |s, c| {
        let estimate = c.estimate();
        let status = c.inner.status();
        tally.push(
            s.t,
            &s.state,
            &estimate,
            &c.inner.mpc().plan(),
            &Solve::of(&status.solver),
        );
        tracking.push(s.t, &s.error(), &s.command);
        sum_ns += c.last_ns;
        max_ns = max_ns.max(c.last_ns);
        if keep_rows {
            rows.push(Row {
                t: s.t,
                reference: s.reference,
                state: s.state,
                estimate,
                command: s.command,
                solve_us: c.last_ns as f64 / 1e3,
                disturbance: s.disturbance,
                disturbance_estimate: None,
            });
        }
    });
    GeofenceRun {
        tally,
        table2: tracking.finish(),
        solve_us_mean: sum_ns as f64 / scenario.cycles.max(1) as f64 / 1e3,
        solve_us_max: max_ns as f64 / 1e3,
        rows,
        rejected: timed.rejected_measurements(),
    }
}
