//! The lowered problem: what [`mod@crate::lower`] computes from a spec and every later phase reads (the
//! condensed QP with its constraint rows and certificate, the filter, the screening), apart from the
//! lowering itself so that the solvers, the certificate and the budget name these types without
//! depending on the phase that forms them.
#![allow(non_snake_case)]

use crate::linalg::{project, Gain};
use crate::lower::constraints::Rows;
use crate::solver::first_order::Parameters;
use mpc_spec::{FilterKind, Method, Scalar};
use nalgebra::{DMatrix, DVector};

/// Where a constrained method lets the reference lie ([`Qp::reference_reach`]), per tracked component.
#[derive(Clone, Debug)]
pub struct Reach {
    /// The least offset of a reference from the tracked output that `[mpc.region]` covers.
    pub lo: DVector<f64>,
    /// The greatest such offset.
    pub hi: DVector<f64>,
    /// The region's `reference_min`: an entry inside the range is never moved.
    pub range_min: DVector<f64>,
    /// The region's `reference_max`.
    pub range_max: DVector<f64>,
}

/// The condensed MPC problem and its solver parameters.
#[derive(Clone, Debug)]
pub struct Qp {
    /// Prediction horizon N.
    pub N: usize,
    /// Control horizon Nc ≤ N (`[mpc] control_horizon`, N when absent): the QP's variables are the plan
    /// V of the Nc free inputs (Nc·nu), and U = T·V ([`crate::lower::blocking`]) holds u_k = v_{Nc−1} for
    /// k ≥ Nc. Every matrix below that acts on the plan (H, Fx, Fr, Fu, Fd, Su, the rows' A) is on V.
    pub Nc: usize,
    /// The move blocks' lengths (Nc of them, summing to N; [`mpc_spec::Mpc::blocks`]): block j's free
    /// input drives its steps. A control horizon is Nc − 1 blocks of one and a last one of N − Nc + 1.
    pub blocks: Vec<usize>,
    /// Solver iterations per control step (resolved from `"auto"`).
    pub iterations: usize,
    /// The suboptimality the iterations must guarantee, if the spec gives one.
    pub tolerance: Option<f64>,
    /// The solver algorithm ([`crate::solver`]).
    pub method: Method,
    /// What the dual active-set method does when a warm solve runs out (`[mpc] restart`): restart cold
    /// in the same step, or fall back and resume from its working set at the next.
    pub restart: mpc_spec::Restart,
    /// Tracked outputs nz: the rows of `[mpc] outputs`, else nx.
    pub nz: usize,
    /// The output map C_z (nz × nx) of `[mpc] outputs`; `None`: the state is tracked (C_z = I).
    pub Cz: Option<DMatrix<f64>>,
    /// Stage state weight Q (nx × nx): C_zᵀ W C_z for an output weight W.
    pub Q: DMatrix<f64>,
    /// Stage input weight R (nu × nu).
    pub R: DMatrix<f64>,
    /// Weight on the moves Δu_k = u_k − u_{k−1} (nu × nu); zero without `r_du`.
    pub R_du: DMatrix<f64>,
    /// Terminal weight Qf (nx × nx): C_zᵀ W_f C_z, or the spec's state weight.
    pub Qf: DMatrix<f64>,
    /// How a stage's reference r_k (nz) enters its cost's linear term, −2 x_kᵀ·Qr·r_k (nx × nz): C_zᵀ W,
    /// and Q itself without outputs.
    pub Qr: DMatrix<f64>,
    /// The terminal Qr: C_zᵀ W_f, or Qf·C_z⁺ for a weight on the state (the reference state of x_N is then
    /// the least-norm state with outputs r_N).
    pub Qfr: DMatrix<f64>,
    /// Sx = [F; F²; …; Fᴺ], (N·nx) × nx, eq. 12.
    pub Sx: DMatrix<f64>,
    /// Su, (N·nx) × (N·nu), eq. 13 (times T: (N·nx) × (Nc·nu)).
    pub Su: DMatrix<f64>,
    /// H = 2(Suᵀ Q_blk Su + R_blk), (N·nu) × (N·nu), eq. 9.
    pub H: DMatrix<f64>,
    /// Fx = 2 Suᵀ Q_blk Sx, (N·nu) × nx: the gradient's dependence on x0 (eq. 10).
    pub Fx: DMatrix<f64>,
    /// Fr = 2 Suᵀ Qr_blk, (N·nu) × (N·nz): the gradient's dependence on the references (eq. 10; Qr = Q
    /// without outputs).
    pub Fr: DMatrix<f64>,
    /// Fu = −2 Dᵀ R_du_blk E, (N·nu) × nu: the gradient's dependence on the last input u_{−1} (D the
    /// block difference matrix, E = [I; 0; …]); zero without `r_du`.
    pub Fu: DMatrix<f64>,
    /// Fd = H·(1_N ⊗ I) + Fu, (N·nu) × nd: the gradient's dependence on the estimated input disturbance d.
    /// With V = U + (1_N ⊗ d) the offset-free problem (prediction with u + d, input cost on u − u_ss,
    /// u_ss = −d, moves unchanged) is the plain one in V with v_{−1} = u_{−1} + d, so f gains exactly
    /// H·(1_N ⊗ d) + Fu·d. Zero columns without disturbance.
    pub Fd: DMatrix<f64>,
    /// Largest eigenvalue of H.
    pub L: f64,
    /// Smallest eigenvalue of H.
    pub mu: f64,
    /// The step size α: 1/L for `step = "auto"`.
    pub step: f64,
    /// Momentum β of the fast gradient method, (1 − √(αμ)) / (1 + √(αμ)); zero for `gradient`.
    pub momentum: f64,
    /// Lower input bounds (nu).
    pub u_min: DVector<f64>,
    /// Upper input bounds (nu).
    pub u_max: DVector<f64>,
    /// The constraints beyond the input box ([`crate::lower::constraints`]); empty for the box alone.
    pub rows: Rows,
    /// The back-offs applied to `rows` (and `x_bounds`), nonzero margins only
    /// ([`crate::lower::backoff`]).
    pub backoff: Vec<crate::lower::backoff::Margin>,
    /// `[mpc] accuracy`: the plan within accuracy·(u_max − u_min) of the exact solution.
    pub accuracy: f64,
    /// The sampled certificate ([`crate::certify::sampling`]): always for `ipm` and `admm` (with ADMM's tuned ρ,
    /// [`crate::certify::evidence::Evidence::rho`]), for a first-order method with `[mpc.region]`.
    pub evidence: Option<crate::certify::evidence::Evidence>,
    /// The hard and soft state bounds `x_min`/`x_max` (nx each, ±∞ where absent): with the region,
    /// what [`Qp::reference_reach`] spans.
    pub x_bounds: (Vec<f64>, Vec<f64>),
}

impl Qp {
    /// The run-time limits of a sampled method's final residuals (the interior-point method's, ADMM's;
    /// none before it is certified).
    pub fn ipm_limits(&self) -> crate::certify::evidence::Limits {
        self.evidence
            .as_ref()
            .map_or(crate::certify::evidence::Limits::NONE, |e| e.limits)
    }

    /// How far the reference may lie from the tracked output, per tracked component ([`Reach`]): lo =
    /// reference_min − the output's largest value, hi = reference_max − its smallest, over the box that
    /// spans `[mpc.region]`'s states and the finite state bounds (interval arithmetic). A constrained
    /// method brings a reference entry that lies outside the region's reference range within
    /// [z0 + lo, z0 + hi] (z0 the output at x0) before the solve ([`Qp::reach_reference`]): a far
    /// reference is then approached as fast as the constraints allow instead of asking the
    /// fixed-iteration solver for a QP far from what the sample certified. An entry inside the range is
    /// never moved, wherever the state is: the QP is then the one docs/methods.md defines. `None` for the
    /// first-order methods and before the certificate.
    pub fn reference_reach(&self) -> Option<Reach> {
        let e = self.evidence.as_ref().filter(|_| !self.method.box_only())?;
        let mut r = e.region.clone();
        let nz = self.nz;
        let nx = r.x_min.len();
        for j in 0..nx {
            let (lo, hi) = (self.x_bounds.0[j], self.x_bounds.1[j]);
            if lo.is_finite() {
                r.x_min[j] = r.x_min[j].min(lo);
            }
            if hi.is_finite() {
                r.x_max[j] = r.x_max[j].max(hi);
            }
        }
        let (lo, hi) = match &self.Cz {
            Some(Cz) => (
                DVector::from_fn(nz, |i, _| {
                    (0..nx)
                        .map(|j| (Cz[(i, j)] * r.x_min[j]).min(Cz[(i, j)] * r.x_max[j]))
                        .sum::<f64>()
                }),
                DVector::from_fn(nz, |i, _| {
                    (0..nx)
                        .map(|j| (Cz[(i, j)] * r.x_min[j]).max(Cz[(i, j)] * r.x_max[j]))
                        .sum::<f64>()
                }),
            ),
            None => (
                DVector::from_column_slice(&r.x_min),
                DVector::from_column_slice(&r.x_max),
            ),
        };
        Some(Reach {
            lo: DVector::from_fn(nz, |i, _| r.reference_min[i] - hi[i]),
            hi: DVector::from_fn(nz, |i, _| r.reference_max[i] - lo[i]),
            range_min: DVector::from_fn(nz, |i, _| r.reference_min[i]),
            range_max: DVector::from_fn(nz, |i, _| r.reference_max[i]),
        })
    }

    /// `window` (N references of nz, each of a predicted step) with every entry outside the region's
    /// reference range brought within [`Qp::reference_reach`] of the output at `x0`; whether any entry
    /// lay outside the range (the status's `reference_beyond_region`).
    pub fn reach_reference(&self, x0: &DVector<f64>, window: &mut [DVector<f64>]) -> bool {
        let Some(reach) = self.reference_reach() else {
            return false;
        };
        let z0 = match &self.Cz {
            Some(Cz) => Cz * x0,
            None => x0.clone(),
        };
        let mut beyond = false;
        for r in window.iter_mut() {
            for i in 0..r.len().min(self.nz) {
                let outside = r[i] < reach.range_min[i] || r[i] > reach.range_max[i];
                beyond |= outside;
                if outside {
                    r[i] = r[i].max(z0[i] + reach.lo[i]).min(z0[i] + reach.hi[i]);
                }
            }
        }
        beyond
    }

    /// The rest plan: [`Qp::rest_input`] at every free step (a cold start, and what warm starts append);
    /// Nc·nu entries.
    pub fn rest_plan(&self) -> DVector<f64> {
        let rest = self.rest_input();
        DVector::from_iterator(
            self.Nc * rest.len(),
            (0..self.Nc).flat_map(|_| rest.iter().copied()),
        )
    }

    /// Whether a control horizon shorter than the prediction horizon, or move blocking, holds one input
    /// over several steps.
    pub fn blocked(&self) -> bool {
        self.Nc < self.N
    }

    /// The plan of the QP's variables V (Nc·nu) expanded to the N steps U = T·V: each step takes the
    /// free input of its block.
    pub fn expand(&self, V: &DVector<f64>) -> DVector<f64> {
        let nu = self.u_min.len();
        DVector::from_iterator(
            self.N * nu,
            crate::lower::block_of_step(&self.blocks)
                .flat_map(|j| (0..nu).map(move |i| V[j * nu + i])),
        )
    }

    /// Whether the blocks are those of a control horizon: one step each, but the last.
    pub fn held_tail(&self) -> bool {
        self.blocks[..self.Nc - 1].iter().all(|&b| b == 1)
    }

    /// The blocking as the spec would write it: `control_horizon = Nc`, or `move_blocking = [...]`.
    pub fn blocking_written(&self) -> String {
        if self.held_tail() {
            format!("`control_horizon = {}`", self.Nc)
        } else {
            let blocks: Vec<String> = self.blocks.iter().map(|b| b.to_string()).collect();
            format!("`move_blocking = [{}]`", blocks.join(", "))
        }
    }

    /// What the algorithm runs with.
    pub fn parameters(&self) -> Parameters {
        Parameters {
            step: self.step,
            momentum: self.momentum,
            mu: self.mu,
            L: self.L,
        }
    }

    /// The input block that warm starts append and cold starts use: zero, projected onto the box
    /// (the paper's zero block whenever the box contains zero).
    pub fn rest_input(&self) -> DVector<f64> {
        DVector::from_iterator(
            self.u_min.len(),
            self.u_min
                .iter()
                .zip(self.u_max.iter())
                .map(|(lo, hi)| project(0.0, *lo, *hi)),
        )
    }
}

/// The linear Kalman filter of Section 2.3.
#[derive(Clone, Debug)]
pub struct Filter {
    /// Disturbance states: nu with `[kalman] disturbance`, else 0. The filter's state is (x, d), na = nx + nd.
    pub nd: usize,
    /// The filter's transition [F G; 0 I] (na × na): x⁺ = F x + G (u + d), d⁺ = d. F without disturbance.
    pub Fa: DMatrix<f64>,
    /// The filter's input matrix [G; 0] (na × nu).
    pub Ga: DMatrix<f64>,
    /// The filter's measurement matrix [C 0] (ny × na).
    pub Ca: DMatrix<f64>,
    /// Process noise covariance (na × na): eq. 3 with symmetric Δt³/2 off-diagonal blocks, then the
    /// disturbance's random walk.
    pub Qn: DMatrix<f64>,
    /// Measurement noise covariance (ny × ny).
    pub Rn: DMatrix<f64>,
    /// Initial (prior) covariance (na × na); the disturbance block is the identity, (m/s²)² for a drone.
    pub P0: DMatrix<f64>,
    /// Time-varying or steady-state.
    pub kind: FilterKind,
    /// The steady-state prior covariance P∞ of the discrete Riccati recursion.
    pub P_inf: DMatrix<f64>,
    /// The steady-state gain K∞ = P∞ Cᵀ (C P∞ Cᵀ + R)⁻¹ (na × ny).
    pub K_inf: DMatrix<f64>,
    /// The entries of the time-varying filter's covariance that can be nonzero
    /// ([`crate::lower::structure::covariance_pattern`]); the emitted filter computes only those.
    pub P_pattern: DMatrix<bool>,
    /// How measurements are screened before they are fused.
    pub screening: Screening,
    /// The minimum-norm correction onto the measurement, [C⁺; 0] (na × ny): re-acquisition moves the
    /// estimate by `C_pinv·(z − C x)`, which makes C x = z and leaves the unmeasured directions and the
    /// disturbance as they were.
    pub C_pinv: DMatrix<f64>,
    /// (C P∞ Cᵀ + R)⁻¹ (ny × ny): the steady-state filter's innovation covariance, inverted, for its gate.
    pub S_inf_inv: DMatrix<f64>,
    /// The steady-state filter's gains after a re-acquisition: the k-th reading it fuses from then on
    /// uses entry k − 1 (gate and correction), the gain of the time-varying filter restarted at P0
    /// ([`crate::linalg::restart_gains`]), and K∞ once the table is used up. Empty for the time-varying filter, which
    /// restarts its own covariance.
    pub restart: Vec<Gain>,
}

/// The default false-rejection probability of the innovation gate: the gate is the χ² quantile with ny
/// degrees of freedom that a consistent filter exceeds this rarely (30.7 for ny = 3; once in about 3.5
/// hours at the paper's 78 Hz).
pub const DEFAULT_GATE_PROBABILITY: f64 = 1e-6;

/// The measurement screening the emitted filter runs, resolved from `[kalman]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Screening {
    /// The threshold on eᵀS⁻¹e above which a reading is rejected; `None`: no gate.
    pub gate: Option<f64>,
    /// The probability that a reading of a consistent filter exceeds the gate (χ² with ny degrees of
    /// freedom); 0 without a gate.
    pub false_rejection: f64,
    /// Bit-identical readings in a row from which the sensor is taken as stuck; `None`: never.
    pub stuck_cycles: Option<u32>,
    /// Consecutive gated, changing readings after which the filter re-acquires.
    pub reacquire_after: u32,
}

impl Screening {
    /// The spec's screening with the default gate resolved for `ny` measurements.
    pub fn resolve(spec: &mpc_spec::Screening, ny: usize) -> Self {
        use statrs::distribution::{ChiSquared, ContinuousCDF};
        let chi2 = ChiSquared::new(ny as f64).ok();
        let gate = match spec.gate {
            mpc_spec::Gate::Off => None,
            mpc_spec::Gate::Threshold(g) => Some(g),
            mpc_spec::Gate::Default => chi2
                .as_ref()
                .map(|d| d.inverse_cdf(1.0 - DEFAULT_GATE_PROBABILITY)),
        };
        let false_rejection = match (gate, &chi2) {
            (Some(g), Some(d)) => d.sf(g),
            _ => 0.0,
        };
        Screening {
            gate,
            false_rejection,
            stuck_cycles: spec.stuck_cycles,
            reacquire_after: spec.reacquire_after,
        }
    }
}

/// Everything `mpc!` computes from a spec.
#[derive(Clone, Debug)]
pub struct Problem {
    /// State dimension.
    pub nx: usize,
    /// Input dimension.
    pub nu: usize,
    /// Measurement dimension.
    pub ny: usize,
    /// Sampling time, s.
    pub dt: f64,
    /// State transition F (nx × nx), eq. 2.
    pub F: DMatrix<f64>,
    /// Input matrix G (nx × nu), eq. 2.
    pub G: DMatrix<f64>,
    /// Measurement matrix C (ny × nx), eq. 2's H (renamed: H is the Hessian here).
    pub C: DMatrix<f64>,
    /// The condensed QP.
    pub qp: Qp,
    /// The filter; `None` without `[kalman]` (state feedback: the controller takes the measured state).
    pub filter: Option<Filter>,
    /// The scalar type to emit.
    pub scalar: Scalar,
    /// The model per input lane, when F, G, Q, Qf and R are all `A ⊗ I_nu` ([`ModelLanes`]).
    pub model_lanes: Option<ModelLanes>,
    /// The method as the spec wrote it (`Auto` when it did not); [`Qp::method`] is the one used.
    pub requested: Method,
    /// What `method = "auto"` weighed ([`crate::plan::choice`]); empty for a written method.
    pub candidates: Vec<crate::certify::evidence::Candidate>,
}

impl Problem {
    /// The filter's disturbance states: nu with `[kalman] disturbance`, else 0 (also without a filter).
    pub fn nd(&self) -> usize {
        self.filter.as_ref().map_or(0, |f| f.nd)
    }

    /// Whether the moves Δu are weighted, so that the MPC depends on the last input.
    pub fn has_moves(&self) -> bool {
        self.qp.R_du.iter().any(|v| *v != 0.0)
    }

    /// Whether the MPC keeps the last input u₋₁: for weighted moves, or for move bounds (rows on u₋₁).
    pub fn keeps_last_input(&self) -> bool {
        self.has_moves() || self.qp.rows.Wu.iter().any(|v| *v != 0.0)
    }
}

/// The model of one input lane: with x ordered component-major (x[s·nu + a] is component s of lane
/// a, as the double integrator's [positions; velocities]), F = F_axis ⊗ I_nu, G = G_axis ⊗ I_nu and the
/// weights likewise, so the matrix-free sweeps run all lanes at once with one set of constants.
#[derive(Clone, Debug)]
pub struct ModelLanes {
    /// F_axis, nx/nu × nx/nu.
    pub F: DMatrix<f64>,
    /// G_axis, nx/nu × 1.
    pub G: DMatrix<f64>,
    /// Q_axis.
    pub Q: DMatrix<f64>,
    /// Qf_axis.
    pub Qf: DMatrix<f64>,
    /// R_axis, 1 × 1.
    pub R: DMatrix<f64>,
}
