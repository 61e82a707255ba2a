//! The validated controller spec: plain values, every one checked by [`crate::load`].

use std::collections::BTreeMap;
use std::ops::Range;

/// An enum whose variants are spelled in a spec: the one place each spelling is written. Gives `ALL`,
/// `NAMES` (in the same order), `name()`, `from_name()`, and a `serde::Serialize` as the spelling.
macro_rules! spelled {
    ($(#[$meta:meta])* pub enum $name:ident { $($(#[$vmeta:meta])* $variant:ident = $spelling:literal,)* }) => {
        $(#[$meta])*
        pub enum $name {
            $($(#[$vmeta])* $variant,)*
        }

        impl $name {
            /// Every variant, in declaration order.
            pub const ALL: &'static [$name] = &[$($name::$variant),*];
            /// The spellings of [`Self::ALL`], in the same order.
            pub const NAMES: &'static [&'static str] = &[$($spelling),*];

            /// The spelling in a spec.
            pub const fn name(self) -> &'static str {
                match self {
                    $($name::$variant => $spelling,)*
                }
            }

            /// The variant spelled `s`.
            pub fn from_name(s: &str) -> Option<Self> {
                Self::ALL.iter().copied().find(|v| v.name() == s)
            }
        }

        impl serde::Serialize for $name {
            fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                s.serialize_str(self.name())
            }
        }
    };
}

/// A byte range into the spec's source text.
pub type Span = Range<usize>;

/// A dense real matrix, row-major.
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    /// Number of rows.
    pub rows: usize,
    /// Number of columns.
    pub cols: usize,
    /// `rows * cols` entries, row after row.
    pub data: Vec<f64>,
}

impl Matrix {
    /// A matrix from its rows; every row must have the same length.
    pub fn from_rows(rows: &[Vec<f64>]) -> Self {
        let cols = rows.first().map_or(0, Vec::len);
        assert!(rows.iter().all(|r| r.len() == cols), "ragged rows");
        Matrix {
            rows: rows.len(),
            cols,
            data: rows.concat(),
        }
    }

    /// A square diagonal matrix.
    pub fn diagonal(diag: &[f64]) -> Self {
        let n = diag.len();
        let mut data = vec![0.0; n * n];
        for (i, d) in diag.iter().enumerate() {
            data[i * n + i] = *d;
        }
        Matrix {
            rows: n,
            cols: n,
            data,
        }
    }

    /// Entry (i, j).
    pub fn get(&self, i: usize, j: usize) -> f64 {
        self.data[i * self.cols + j]
    }

    /// Every entry multiplied by `k`.
    pub fn scaled(&self, k: f64) -> Self {
        Matrix {
            data: self.data.iter().map(|v| v * k).collect(),
            ..self.clone()
        }
    }

    /// The largest asymmetry |a_ij − a_ji| relative to √(|a_ii·a_jj|), the scale of the pair (infinite when a
    /// pair differs where that scale is zero); 0 for an exactly symmetric matrix, infinite for a non-square one.
    pub fn asymmetry(&self) -> f64 {
        if self.rows != self.cols {
            return f64::INFINITY;
        }
        let mut worst = 0.0_f64;
        for i in 0..self.rows {
            for j in 0..i {
                let difference = (self.get(i, j) - self.get(j, i)).abs();
                if difference == 0.0 {
                    continue;
                }
                let scale = (self.get(i, i) * self.get(j, j)).abs().sqrt();
                worst = worst.max(difference / scale);
            }
        }
        worst
    }

    /// Whether the matrix is square and symmetric up to [`SYMMETRY_TOLERANCE`] of each pair's scale
    /// √(|a_ii·a_jj|): a Riccati solution printed to ten digits passes, a typo does not.
    pub fn is_symmetric(&self) -> bool {
        self.asymmetry() <= SYMMETRY_TOLERANCE
    }
}

/// The most iterations a spec may ask for, written or chosen by `iterations = "auto"`.
pub const MAX_ITERATIONS: usize = 100_000;

/// The asymmetry a weight or covariance may have, relative to √(|a_ii·a_jj|); the compiler uses (A + Aᵀ)/2.
pub const SYMMETRY_TOLERANCE: f64 = 1e-9;

/// The plant model, `[model]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The dynamics.
    pub kind: ModelKind,
    /// The sampling time in seconds.
    pub dt: f64,
}

/// Which plant `[model] type` names.
#[derive(Clone, Debug, PartialEq)]
pub enum ModelKind {
    /// The paper's eq. 2: per axis a position and a velocity driven by an acceleration.
    /// The state is the positions of every axis, then their velocities; the measurement is the positions.
    DoubleIntegrator {
        /// Number of independent axes.
        axes: usize,
    },
    /// A linear plant x⁺ = A x + B u (or ẋ = A x + B u, see `time`), y = C x.
    Linear {
        /// nx × nx.
        a: Matrix,
        /// nx × nu.
        b: Matrix,
        /// ny × nx; the identity when not written (only without `[kalman]`, which is what uses it).
        c: Matrix,
        /// Whether `a` and `b` are the sampled model or the continuous-time one the compiler samples.
        time: TimeDomain,
    },
}

spelled! {
    /// The time domain of a `linear` model's `a` and `b`, `[model] time`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum TimeDomain {
        /// x⁺ = A x + B u over one sampling period `dt`: used as written.
        Discrete = "discrete",
        /// ẋ = A x + B u: sampled exactly with a zero-order hold over `dt` (`[kalman] q` is then a
        /// spectral density, sampled by Van Loan's method).
        Continuous = "continuous",
    }
}

spelled! {
    /// How ADMM computes its x-update, `[mpc] admm_form` (the compiler's choice when absent or
    /// `"auto"`). The two give the same iterates in exact arithmetic.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum AdmmForm {
        /// x̃ = K·(σx − q + Cᵀ(Rz − y)), K applied through its factor computed at build time.
        Direct = "direct",
        /// x̃ = x + K·(CᵀR(z − Cx) − (Px + q + Cᵀy)): one product with P and one with C more an
        /// iteration, and a fixed point that the rounding of the factor does not move.
        Residual = "residual",
    }
}

spelled! {
    /// What the dual active-set method does when a warm solve runs out of its changes or its budget of
    /// work, `[mpc] restart`.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub enum Restart {
        /// Restart cold in the same step (the default): the step ends at the optimum wherever the
        /// sampled (or exact) cold count holds, and is priced at a warm solve plus a cold one.
        #[default]
        Cold = "cold",
        /// Fall back to the held plan and resume from the working set where the solve stopped at the
        /// next step: no solve, cold or warm, spends more than the warm budget, and the step is priced
        /// at one such solve. For a target whose period the cold restart does not fit.
        Continue = "continue",
    }
}

/// `[mpc] iterations`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Iterations {
    /// A fixed count.
    Fixed(usize),
    /// The smallest count the a priori bound guarantees for `tolerance`.
    Auto,
}

spelled! {
    /// How the QP is solved, `[mpc] method`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Method {
        /// Nesterov's fast gradient method with constant momentum.
        Fgm = "fgm",
        /// Projected gradient, the paper's Algorithm 1.
        Gradient = "gradient",
        /// A fixed-iteration primal-dual interior-point method (Mehrotra's predictor-corrector) in f64:
        /// for state, output and rate constraints and ill-conditioned plants.
        Ipm = "ipm",
        /// ADMM (OSQP's operator splitting) with a build-time factor and a build-time tuned penalty ρ,
        /// in the module's scalar: for the same constraints as `ipm` on targets without f64 hardware.
        Admm = "admm",
        /// A dual active-set method (Goldfarb and Idnani's, as DAQP) in f64, its factor, Gram matrix
        /// and independent blocks computed at build time, warm-started from the last working set: for
        /// the same constraints as `ipm`, at the optimum in a few changes of the working set.
        ActiveSet = "active_set",
        /// The compiler's choice (the default): the cheapest method that its certificate shows
        /// reaching `accuracy`, resolved at build time; FGM-only keys (a numeric `step`, `tolerance`)
        /// choose `fgm`.
        Auto = "auto",
    }
}

impl Method {
    /// Whether the method solves the input box only (a first-order method), so that state rows,
    /// rate bounds and soft constraints need another.
    pub const fn box_only(self) -> bool {
        matches!(self, Method::Fgm | Method::Gradient)
    }
}

/// The accuracy `[mpc] accuracy` asks for when it is not written: the plan within 1e-3 of the input
/// span of the exact solution, and rows violated by at most 1e-3 of their bound's scale.
pub const DEFAULT_ACCURACY: f64 = 1e-3;

/// The constraints of `[mpc]` besides the input box: `x_min`/`x_max` (with `x_soft`), `du_min`/`du_max`
/// and the row groups `[[mpc.constraint]]`. Absent entries are ±∞.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Constraints {
    /// Lower bounds on the predicted states x_1 … x_N (nx entries, −∞ where unbounded); empty when
    /// `x_min` is not written.
    pub x_min: Vec<f64>,
    /// Upper bounds on the predicted states (nx, +∞ where unbounded); empty when not written.
    pub x_max: Vec<f64>,
    /// `x_soft`: the weight of the exact (L1) penalty on a violation of `x_min`/`x_max`; `None`: hard.
    pub x_soft: Option<f64>,
    /// `x_backoff`: how far `x_min`/`x_max` are pulled in (constraint tightening); `None`: not at all.
    pub x_backoff: Option<Backoff>,
    /// Lower bounds on the moves u_k − u_{k−1}, k = 0 … N−1 (nu); empty when `du_min` is not written.
    pub du_min: Vec<f64>,
    /// Upper bounds on the moves (nu); empty when not written.
    pub du_max: Vec<f64>,
    /// `[[mpc.constraint]]`, in the order written.
    pub rows: Vec<RowGroup>,
}

impl Constraints {
    /// Whether nothing beyond the input box is constrained.
    pub fn is_empty(&self) -> bool {
        self.x_min.is_empty()
            && self.x_max.is_empty()
            && self.du_min.is_empty()
            && self.du_max.is_empty()
            && self.rows.is_empty()
    }
}

impl Constraints {
    /// Whether anything besides the input box is constrained.
    pub fn any(&self) -> bool {
        self.has_state_bounds() || self.has_move_bounds() || !self.rows.is_empty()
    }

    /// Whether `x_min` or `x_max` bounds some state.
    pub fn has_state_bounds(&self) -> bool {
        self.x_min.iter().chain(&self.x_max).any(|b| b.is_finite())
    }

    /// Whether `du_min` or `du_max` bounds some move.
    pub fn has_move_bounds(&self) -> bool {
        self.du_min
            .iter()
            .chain(&self.du_max)
            .any(|b| b.is_finite())
    }

    /// Whether some constraint is soft.
    pub fn any_soft(&self) -> bool {
        self.x_soft.is_some() || self.rows.iter().any(|r| r.soft.is_some())
    }
}

/// One `[[mpc.constraint]]`: lower ≤ Ax·x_k + Au·u_k ≤ upper at every predicted step (docs/spec.md states
/// the stages: k = 0 … N−1 where the row has an `au`, and the terminal x_N through `ax` alone).
#[derive(Clone, Debug, PartialEq)]
pub struct RowGroup {
    /// rows × nx.
    pub ax: Matrix,
    /// rows × nu; zero when not written.
    pub au: Matrix,
    /// One per row, −∞ where unbounded below.
    pub lower: Vec<f64>,
    /// One per row, +∞ where unbounded above.
    pub upper: Vec<f64>,
    /// The exact penalty's weight on a violation; `None`: hard.
    pub soft: Option<f64>,
    /// How far `lower`/`upper` are pulled in (constraint tightening); `None`: not at all.
    pub backoff: Option<Backoff>,
}

/// A back-off (constraint tightening), `[mpc] x_backoff` or a group's `backoff`: each finite bound is
/// pulled in by a margin, lower + m ≤ row ≤ upper − m, so that the true state keeps a bound the plan of
/// the estimate keeps (docs/spec.md, "Back-off").
#[derive(Clone, Debug, PartialEq)]
pub enum Backoff {
    /// A margin per entry in the bound's units: nx for `x_backoff`, one per row for a group.
    Margin(Vec<f64>),
    /// `"<z>sigma"`: z standard deviations of the Kalman filter's steady-state estimation error
    /// along the row, √(a·P∞·aᵀ) for the row's state coefficients a, computed by the compiler.
    Sigmas(f64),
}

spelled! {
    /// How the iteration count over `[mpc.region]` is certified, `[mpc.region] certificate`.
    #[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
    pub enum Certificate {
        /// The dual active-set method's exact count over the region (a partition of the parameter box,
        /// constant reference windows), falling back to the sample where the build's budget runs out;
        /// the sampled certificate for the other methods, which have no exact count.
        #[default]
        Exact = "exact",
        /// The sample only: corners, seeded draws and closed-loop sequences.
        Sampled = "sampled",
    }
}

/// `[mpc.region]`: where the compiler samples states, references (and the last input, the disturbance)
/// to certify an interior-point method empirically. Absent entries default from the state bounds.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Region {
    /// Lower corner of the sampled states (nx); empty: `x_min`.
    pub x_min: Vec<f64>,
    /// Upper corner of the sampled states (nx); empty: `x_max`.
    pub x_max: Vec<f64>,
    /// Lower corner of the sampled references (nz); empty: the tracked outputs over the state region.
    pub reference_min: Vec<f64>,
    /// Upper corner of the sampled references (nz); empty: likewise.
    pub reference_max: Vec<f64>,
    /// Seeded random draws (besides the corners); `None`: the compiler's default.
    pub samples: Option<usize>,
    /// Closed-loop sequences, warm-started, each of [`Region::steps`] steps; `None`: the default.
    pub sequences: Option<usize>,
    /// Steps per closed-loop sequence; `None`: the default.
    pub steps: Option<usize>,
    /// `certificate`: exact (the default, where the method has an exact count) or sampled.
    pub certificate: Certificate,
    /// `exact_lps`: the feasibility LPs the exact count may solve per block before it falls back to
    /// the sample; `None`: the compiler's default (`codegen::budget::EXACT_LPS`).
    pub exact_lps: Option<usize>,
}

/// The solver's step size, `[mpc] step`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// 1/L, L the largest eigenvalue of the Hessian.
    Auto,
    /// A given step size.
    Fixed(f64),
}

/// The MPC problem and solver, `[mpc]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Mpc {
    /// Prediction horizon N.
    pub horizon: usize,
    /// The move blocks: their lengths, summing to N, one free input each (`move_blocking`, MATLAB's
    /// vector `ControlHorizon`; from `control_horizon = Nc` Nc − 1 blocks of one step and one of the
    /// N − Nc + 1 held ones; N blocks of one when both are absent). The QP has `blocks.len()`·nu decision
    /// variables, and u_k is the free input of the block that holds step k.
    pub blocks: Vec<usize>,
    /// Solver iterations per control step.
    pub iterations: Iterations,
    /// The suboptimality the iterations must guarantee, relative to the initial gap:
    /// J(U_k) − J* ≤ tolerance·(J(U_0) − J*).
    pub tolerance: Option<f64>,
    /// Whether fixed iterations below what `tolerance` needs are an error rather than a warning.
    pub strict: bool,
    /// Whether a closed loop found unstable is accepted.
    pub accept_unstable: bool,
    /// The solver: as written, or `fgm` where `method = "auto"` (the default) meets FGM-only keys;
    /// `Auto` is resolved by the compiler.
    pub method: Method,
    /// The method as written (`Auto` when not written).
    pub method_requested: Method,
    /// The step size.
    pub step: Step,
    /// ADMM's x-update as written; `None`: the certificate's choice (direct, or residual where the
    /// direct form misses `accuracy` in f32).
    pub admm_form: Option<AdmmForm>,
    /// The dual active-set method's answer to a warm solve that runs out, `restart` (cold by default).
    pub restart: Restart,
    /// The tracked outputs z = C_z x, `outputs` (nz × nx); `None`: the whole state is tracked (C_z = I).
    pub outputs: Option<Matrix>,
    /// Stage weight on the tracked outputs, nz × nz (nz = nx without `outputs`).
    pub q: Matrix,
    /// Stage input weight R, nu × nu: positive definite, or semidefinite with `r_du`.
    pub r: Matrix,
    /// Weight on the moves Δu_k = u_k − u_{k−1}, nu × nu (`r_du`); `None`: no move suppression.
    pub r_du: Option<Matrix>,
    /// Terminal weight Qf (`qf`, `qf_scale`·Q, or Q): on the outputs (nz × nz), or on the state (nx × nx)
    /// when [`Mpc::qf_on_state`].
    pub qf: Matrix,
    /// Whether `qf` weighs the state x_N (nx × nx, e.g. a Riccati solution) rather than the outputs: only
    /// with `outputs`, for a `qf` of nx × nx when nz ≠ nx.
    pub qf_on_state: bool,
    /// `qf = "lqr"`: the terminal weight is the solution P of the plant's discrete algebraic Riccati
    /// equation (with `r_du`, the state block of that of the plant augmented with u₋₁), on the state
    /// x_N. The compiler solves it when it lowers the QP (`codegen::linalg::dare`); [`Mpc::qf`] then
    /// holds the stage weight `q` and is not read.
    pub qf_lqr: bool,
    /// Lower input bound per input.
    pub u_min: Vec<f64>,
    /// Upper input bound per input.
    pub u_max: Vec<f64>,
    /// State, rate and general constraints beyond the input box.
    pub constraints: Constraints,
    /// `accuracy`: |U − U*|∞ ≤ accuracy·(u_max − u_min) and a row violation ≤ accuracy·max(1, |bound|).
    pub accuracy: f64,
    /// `[mpc.region]`, where an interior-point method is certified.
    pub region: Region,
}

impl Mpc {
    /// The control horizon: the number of free inputs, one per move block (N without blocking).
    pub fn control_horizon(&self) -> usize {
        self.blocks.len()
    }
}

/// `blocks` cut at `horizon` steps: the blocks that fit, the one that crosses it shortened (MATLAB's
/// truncation of a blocking vector whose sum exceeds the prediction horizon).
pub fn truncated_blocks(blocks: &[usize], horizon: usize) -> Vec<usize> {
    let mut out = Vec::new();
    let mut left = horizon;
    for &b in blocks {
        if left == 0 {
            break;
        }
        out.push(b.min(left));
        left -= b.min(left);
    }
    out
}

/// The move blocks of a control horizon Nc ≤ N: Nc − 1 blocks of one step, then one holding the last
/// N − Nc + 1 steps (N blocks of one for Nc = N).
pub fn held_after(horizon: usize, control_horizon: usize) -> Vec<usize> {
    let nc = control_horizon.clamp(1, horizon.max(1));
    let mut blocks = vec![1; nc - 1];
    blocks.push(horizon + 1 - nc);
    blocks
}

/// The filter's noise model, from `[kalman]`.
#[derive(Clone, Debug, PartialEq)]
pub enum KalmanNoise {
    /// White acceleration noise (paper eq. 3) and independent position noise; double integrator only.
    WhiteAcceleration {
        /// Acceleration noise standard deviation, m/s².
        sigma_a: f64,
        /// Measurement noise standard deviation per measured output.
        sigma_meas: Vec<f64>,
    },
    /// Explicit covariances.
    Covariances {
        /// Process noise covariance, nx × nx.
        q: Matrix,
        /// Measurement noise covariance, ny × ny.
        r: Matrix,
    },
}

spelled! {
    /// Which Kalman filter is emitted, `[kalman] filter`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum FilterKind {
        /// The covariance is propagated at run time.
        TimeVarying = "time_varying",
        /// The gain is the limit of the time-varying one, solved at compile time.
        SteadyState = "steady_state",
    }
}

/// The state estimator, `[kalman]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Kalman {
    /// Process and measurement noise.
    pub noise: KalmanNoise,
    /// Initial covariance, nx × nx.
    pub p0: Matrix,
    /// Filter kind.
    pub filter: FilterKind,
    /// The random-walk standard deviation per step of a constant input disturbance per input channel,
    /// estimated by the filter and cancelled by the MPC (offset-free MPC); `None`: no disturbance model.
    pub disturbance: Option<Vec<f64>>,
    /// How measurements are screened before they are fused.
    pub screening: Screening,
}

/// How the filter screens a measurement before fusing it: `[kalman] gate`, `stuck_cycles` and
/// `reacquire_after`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Screening {
    /// The χ² gate on the normalized innovation squared.
    pub gate: Gate,
    /// Bit-identical readings in a row from which the sensor is taken as stuck; `None`: never.
    pub stuck_cycles: Option<u32>,
    /// Consecutive gated readings, each different from the one before, after which the filter
    /// re-acquires from the measurement.
    pub reacquire_after: u32,
}

/// Bit-identical readings in a row that make a stuck sensor when `stuck_cycles` is not written.
pub const DEFAULT_STUCK_CYCLES: u32 = 10;
/// Consecutive gated, changing readings that make the filter re-acquire when `reacquire_after` is not
/// written.
pub const DEFAULT_REACQUIRE_AFTER: u32 = 8;

/// `[kalman] gate`: the threshold on the normalized innovation squared eᵀS⁻¹e.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Gate {
    /// Not written: the χ² quantile with ny degrees of freedom at the compiler's default
    /// false-rejection probability.
    Default,
    /// A threshold written in the spec.
    Threshold(f64),
    /// `"off"`: every finite reading is fused.
    Off,
}

impl Default for Screening {
    fn default() -> Self {
        Screening {
            gate: Gate::Default,
            stuck_cycles: Some(DEFAULT_STUCK_CYCLES),
            reacquire_after: DEFAULT_REACQUIRE_AFTER,
        }
    }
}

spelled! {
    /// The floating-point type of the emitted code, `[codegen] scalar`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq)]
    pub enum Scalar {
        /// `f32`.
        F32 = "f32",
        /// `f64`.
        F64 = "f64",
    }
}

/// Code generation options, `[codegen]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Codegen {
    /// The emitted scalar type.
    pub scalar: Scalar,
    /// How the solver's products are emitted; `Auto` lets the compiler's cost model choose.
    pub emission: Emission,
    /// The machine the controller runs on.
    pub target: Target,
    /// Its clock in Hz (`clock_hz`, positive and finite), for the period check; `None`: the target's
    /// default (`codegen::target`: 667 MHz for the Cortex-A9, 168 MHz for the Cortex-M4F). Only with a
    /// target other than the host, which has no cycle model to time.
    pub clock_hz: Option<f64>,
}

spelled! {
    /// The machine the controller runs on, `[codegen] target`: what the compiler knows of its FPU, SIMD
    /// and clock (`codegen::target` has the figures). It changes no emitted code; it decides which
    /// methods the machine can run and whether a control step fits its sampling period.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Target {
        /// The building machine, or any with f64 in hardware and no fixed clock (the default).
        Host = "host",
        /// The Cortex-A9 of a Zynq-7000: VFPv3 (f64 in hardware) and NEON.
        CortexA9 = "cortex-a9",
        /// A Cortex-M4F such as the STM32F405: a single-precision FPU, f64 in software.
        CortexM4f = "cortex-m4f",
    }
}

impl Target {
    /// Whether the machine computes f64 in hardware.
    pub const fn has_f64(self) -> bool {
        !matches!(self, Target::CortexM4f)
    }
}

spelled! {
    /// How the gradient ∇J = H·U + f is emitted, `[codegen] emission`.
    #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
    pub enum Emission {
        /// The compiler's cost model chooses (`mpcc check` prints it).
        Auto = "auto",
        /// Every nonzero of H inlined as a constant, one statement per row.
        Unrolled = "unrolled",
        /// A loop over H stored as a constant table: code size independent of the horizon.
        Table = "table",
        /// H = H_axis ⊗ I: the inputs' components run side by side in SIMD lanes and share one table.
        Lanes = "lanes",
        /// No H at all: a forward sweep of the dynamics and a backward adjoint sweep, O(N) per iteration.
        MatrixFree = "matrix_free",
    }
}

/// The source spans of the spec's keys, by dotted path (`"mpc.step"`), for diagnostics raised after parsing.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Spans(pub(crate) BTreeMap<String, Span>);

impl Spans {
    /// The span of the value at `path` (`"mpc.q"`), or of the table (`"mpc"`).
    pub fn get(&self, path: &str) -> Option<Span> {
        self.0.get(path).cloned()
    }
}

/// A complete, validated controller spec.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    /// `[model]`.
    pub model: Model,
    /// `[mpc]`.
    pub mpc: Mpc,
    /// `[kalman]`; `None`: state feedback, the controller takes the measured state.
    pub kalman: Option<Kalman>,
    /// `[codegen]`.
    pub codegen: Codegen,
    /// Where each key was written.
    pub spans: Spans,
}

impl Spec {
    /// State dimension nx.
    pub fn nx(&self) -> usize {
        self.model.kind.nx()
    }
    /// Input dimension nu.
    pub fn nu(&self) -> usize {
        self.model.kind.nu()
    }
    /// Measurement dimension ny: the model's outputs with a filter, the state without one.
    pub fn ny(&self) -> usize {
        if self.kalman.is_some() {
            self.model.kind.ny()
        } else {
            self.nx()
        }
    }
    /// Tracked-output dimension nz: the rows of `outputs`, else nx.
    pub fn nz(&self) -> usize {
        self.mpc.outputs.as_ref().map_or(self.nx(), |c| c.rows)
    }
}

impl ModelKind {
    /// State dimension nx.
    pub fn nx(&self) -> usize {
        match self {
            ModelKind::DoubleIntegrator { axes } => 2 * axes,
            ModelKind::Linear { a, .. } => a.rows,
        }
    }
    /// Input dimension nu.
    pub fn nu(&self) -> usize {
        match self {
            ModelKind::DoubleIntegrator { axes } => *axes,
            ModelKind::Linear { b, .. } => b.cols,
        }
    }
    /// Measurement dimension ny.
    pub fn ny(&self) -> usize {
        match self {
            ModelKind::DoubleIntegrator { axes } => *axes,
            ModelKind::Linear { c, .. } => c.rows,
        }
    }
}
