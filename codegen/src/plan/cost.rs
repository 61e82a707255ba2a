//! The cost model that chooses how the solver's gradient ∇J = H·U + f is emitted, and that `mpcc check`
//! prints. Every count comes from the lowered matrices (nonzeros in the emitted scalar type); each form
//! ([`crate::solver::first_order::form`]) computes its own [`Estimate`] with the weights here.
//!
//! - `unrolled`: one multiply-add per nonzero of H, each coefficient inlined. Fastest for small sparse
//!   H, but its code grows with N² and must fit the instruction cache.
//! - `table`: a loop over H as a constant table, every entry multiplied (zeros too); code size does not
//!   depend on N, and the loop runs in SIMD lanes down each column.
//! - `lanes`: with H = H_axis ⊗ I (see [`crate::lower::structure`]) the input's components run side by side in
//!   SIMD lanes and share the N × N table H_axis: N² vector multiply-adds per iteration.
//! - `matrix_free`: no H. A forward sweep of the dynamics and a backward adjoint sweep, O(N) per
//!   iteration, but a recursion from step to step whose latency the hardware cannot hide, and vectors
//!   that go through memory between operations.
//!
//! The score is the expected time of one iteration in vector multiply-adds of four lanes: a scalar
//! multiply-add counts one, a 4-lane one counts one, and the matrix-free sweeps' operations count
//! [`SWEEP`] (scalar) or [`SWEEP_IN_LANES`] (lane vectors) for the latency of their recursion. `auto` takes the lowest score among the choices whose code fits
//! [`CODE_BUDGET`].

use mpc_spec::Emission;

/// Bytes of code the gradient may take under `auto`: half the Cortex-A9's 32 KiB L1 instruction cache,
/// the other half left to the filter, the projection and the caller.
pub const CODE_BUDGET: usize = 16 * 1024;
/// The SIMD width the score assumes (NEON's q registers and SSE hold four f32).
pub const VECTOR_WIDTH: usize = 4;
/// The weight of a scalar multiply-add of the matrix-free sweeps: a recursion from step to step whose
/// latency the hardware cannot hide.
pub const SWEEP: f64 = 1.5;
/// The weight of a lane-vector operation of the sweeps in lanes, from the emulated A9 (BENCHMARKS.md):
/// `matrix_free` costs about 180 instructions per step and iteration (15 vector operations, each loading
/// and storing its vectors, and the separate projected step), the `lanes` product about 1.75 per vector
/// multiply-add. The measured crossover lies between N = 60 (`lanes` 236,230 instructions per cycle,
/// `matrix_free` 336,260) and N = 100 (604,050 against 559,810); this weight puts it at N ≈ 82.
pub const SWEEP_IN_LANES: f64 = 5.5;
/// Bytes of A32 code per inlined multiply-add: a literal-pool load (4), its literal (4), the multiply-add (4).
pub const BYTES_PER_INLINED_MAC: usize = 12;
/// Bytes of a loop over a constant table: the loop, its address arithmetic, the lane loads and stores.
pub const BYTES_OF_A_LOOP: usize = 256;

/// What one emission choice costs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Estimate {
    /// The choice.
    pub emission: Emission,
    /// Why it cannot be used for this problem, if it cannot.
    pub unavailable: Option<String>,
    /// Scalar multiply-adds of one iteration's gradient (padding lanes included).
    #[serde(rename = "macs_per_iteration")]
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

/// The lowest-scoring eligible choice (`table` always is: its code does not grow).
pub fn choose(estimates: &[Estimate]) -> Emission {
    estimates
        .iter()
        .filter(|e| e.eligible())
        .min_by(|a, b| a.score.total_cmp(&b.score))
        .map_or(Emission::Table, |e| e.emission)
}
