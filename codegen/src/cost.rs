//! The cost model that chooses how the solver's gradient ∇J = H·U + f is emitted, and that `mpcc check`
//! prints. Every count comes from the lowered matrices (nonzeros in the emitted scalar type).
//!
//! - `unrolled`: one multiply-add per nonzero of H, each coefficient inlined. Fastest for small sparse
//!   H, but its code grows with N² and must fit the instruction cache.
//! - `table`: a loop over H as a constant table, every entry multiplied (zeros too); code size does not
//!   depend on N, and the loop runs in SIMD lanes down each column.
//! - `lanes`: with H = H_axis ⊗ I (see [`crate::structure`]) the input's components run side by side in
//!   SIMD lanes and share the N × N table H_axis: N² vector multiply-adds per iteration.
//! - `matrix_free`: no H. A forward sweep of the dynamics and a backward adjoint sweep, O(N) per
//!   iteration, but a recursion from step to step whose latency the hardware cannot hide, and vectors
//!   that go through memory between operations.
//!
//! The score is the expected time of one iteration in vector multiply-adds of four lanes: a scalar
//! multiply-add counts one, a 4-lane one counts one, and the matrix-free sweeps' operations count
//! [`SWEEP`] (scalar) or [`SWEEP_IN_LANES`] (lane vectors) for the latency of their recursion. `auto` takes the lowest score among the choices whose code fits
//! [`CODE_BUDGET`].
#![allow(non_snake_case)]

use crate::emit::tokens::Num;
use crate::lower::Problem;
use mpc_spec::{Emission, Method};
use nalgebra::DMatrix;

/// Bytes of code the gradient may take under `auto`: half the Cortex-A9's 32 KiB L1 instruction cache,
/// the other half left to the filter, the projection and the caller.
pub const CODE_BUDGET: usize = 16 * 1024;
/// The SIMD width the score assumes (NEON's q registers and SSE hold four f32).
pub const VECTOR_WIDTH: usize = 4;
/// The weight of a scalar multiply-add of the matrix-free sweeps: a recursion from step to step whose
/// latency the hardware cannot hide.
const SWEEP: f64 = 1.5;
/// The weight of a lane-vector operation of the sweeps in lanes, from the emulated A9 (BENCHMARKS.md):
/// `matrix_free` costs about 180 instructions per step and iteration (15 vector operations, each loading
/// and storing its vectors, and the separate projected step), the `lanes` product about 1.75 per vector
/// multiply-add. The measured crossover lies between N = 60 (`lanes` 236,230 instructions per cycle,
/// `matrix_free` 336,260) and N = 100 (604,050 against 559,810); this weight puts it at N ≈ 82.
const SWEEP_IN_LANES: f64 = 5.5;
/// Bytes of A32 code per inlined multiply-add: a literal-pool load (4), its literal (4), the multiply-add (4).
const BYTES_PER_INLINED_MAC: usize = 12;
/// Bytes of a loop over a constant table: the loop, its address arithmetic, the lane loads and stores.
const BYTES_OF_A_LOOP: usize = 256;

/// What one emission choice costs.
#[derive(Clone, Debug, PartialEq)]
pub struct Estimate {
    /// The choice.
    pub emission: Emission,
    /// Why it cannot be used for this problem, if it cannot.
    pub unavailable: Option<String>,
    /// Scalar multiply-adds of one iteration's gradient (padding lanes included).
    pub macs: usize,
    /// The score: one iteration's gradient in 4-lane vector multiply-adds (lower is faster).
    pub score: f64,
    /// Estimated bytes of code for the gradient (A32).
    pub code_bytes: usize,
    /// Bytes of constant tables read by the gradient.
    pub table_bytes: usize,
}

impl Estimate {
    /// Whether `auto` may take it.
    pub fn eligible(&self) -> bool {
        self.unavailable.is_none() && self.code_bytes <= CODE_BUDGET
    }
}

/// Lanes of the `lanes` form: the input's components padded to a power of two, so that three axes fill
/// one 4-lane register.
pub fn lane_count(nu: usize) -> usize {
    nu.next_power_of_two()
}

/// Entries per plan step in the emitted code: padded lanes for `lanes`, and for `matrix_free` when its
/// sweeps run in lanes (the model has the lane structure); the NU inputs otherwise.
pub fn plan_lanes(p: &Problem) -> usize {
    match p.emission {
        Emission::Lanes => lane_count(p.nu),
        Emission::MatrixFree if p.model_lanes.is_some() => lane_count(p.nu),
        _ => p.nu,
    }
}

/// Every choice's estimate, in the order of [`Emission`].
pub fn estimates(p: &Problem) -> Vec<Estimate> {
    let num = Num(p.scalar);
    let nnz = |M: &DMatrix<f64>| num.nonzeros(M);
    let qp = &p.qp;
    let (N, nu) = (qp.N, p.nu);
    let nz = N * nu;
    let size = num.bytes();

    let unrolled = Estimate {
        emission: Emission::Unrolled,
        unavailable: None,
        macs: nnz(&qp.H),
        score: nnz(&qp.H) as f64,
        code_bytes: nnz(&qp.H) * BYTES_PER_INLINED_MAC,
        table_bytes: 0,
    };
    let table = Estimate {
        emission: Emission::Table,
        unavailable: None,
        macs: nz * nz,
        score: (nz * nz) as f64 / VECTOR_WIDTH as f64,
        code_bytes: BYTES_OF_A_LOOP,
        table_bytes: nz * nz * size,
    };
    let lanes = lane_count(nu);
    let lanes = Estimate {
        emission: Emission::Lanes,
        unavailable: match &qp.H_axis {
            Some(_) => None,
            None => Some(format!("H is not H_axis ⊗ I_{nu}")),
        },
        macs: N * N * lanes,
        score: (N * N * lanes.div_ceil(VECTOR_WIDTH)) as f64,
        code_bytes: BYTES_OF_A_LOOP,
        // H_BLOCKS: H_axis in blocks of four rows, the last one zero-padded.
        table_bytes: 4 * N.div_ceil(4) * N * size,
    };
    // Per step: x⁺ = F x + G u forward; λ = 2W e + Fᵀ λ⁺ and g = Gᵀ λ⁺ + 2R u backward, e = x − r.
    // With the model in lanes ([`crate::lower::ModelLanes`]) every operation is one lane vector.
    let ([F, G, Q, Qf, R], width, weight) = match &p.model_lanes {
        Some(m) => (
            [&m.F, &m.G, &m.Q, &m.Qf, &m.R],
            lane_count(nu),
            SWEEP_IN_LANES,
        ),
        None => ([&p.F, &p.G, &qp.Q, &qp.Qf, &qp.R], 1, SWEEP),
    };
    let step = 2 * nnz(F) + 2 * nnz(G) + nnz(Q).max(nnz(Qf)) + nnz(R) + F.nrows();
    let matrix_free = Estimate {
        emission: Emission::MatrixFree,
        unavailable: None,
        macs: N * step * width,
        score: weight * (N * step * width.div_ceil(VECTOR_WIDTH)) as f64,
        // The body of one step, with both weightings (stage and terminal) unrolled.
        code_bytes: (step + nnz(Qf)) * BYTES_PER_INLINED_MAC + BYTES_OF_A_LOOP,
        table_bytes: 0,
    };
    vec![unrolled, table, lanes, matrix_free]
}

/// The lowest-scoring eligible choice (`table` always is: its code does not grow).
pub fn choose(estimates: &[Estimate]) -> Emission {
    estimates
        .iter()
        .filter(|e| e.eligible())
        .min_by(|a, b| a.score.total_cmp(&b.score))
        .map_or(Emission::Table, |e| e.emission)
}

/// Multiply-adds of one iteration besides the gradient: the projected step, and the momentum of FGM.
pub fn update_macs(p: &Problem) -> usize {
    let width = plan_lanes(p);
    let n = p.qp.N * width;
    n + if p.qp.method == Method::Fgm { n } else { 0 }
}
