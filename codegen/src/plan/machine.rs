//! The machines of `[codegen] target`: f64 in hardware, SIMD, clock, and the estimated cycles of a
//! multiply-add. Where the figures come from: [`crate::plan::target`].

use mpc_spec::{Scalar, Target};

/// The SIMD the emitted code can use on a machine.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Simd {
    /// None assumed: the portable kernels (which LLVM may vectorize by itself).
    None,
    /// NEON, 4 f32 lanes (no f64): the lane kernels of `form::neon`.
    Neon,
}

/// What the compiler knows of one target.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Machine {
    /// The spelling in `[codegen] target`.
    pub target: Target,
    /// The processor, in prose.
    pub processor: &'static str,
    /// Whether f64 is computed in hardware (else in software, compiler-builtins' soft float).
    pub f64_in_hardware: bool,
    /// The SIMD unit.
    pub simd: Simd,
    /// The nominal clock, Hz; `None` for the host, which has no fixed one.
    pub clock_hz: Option<f64>,
    /// Estimated cycles per multiply-add in f32 (the module's table).
    pub cycles_per_mac_f32: f64,
    /// Estimated cycles per multiply-add in f64.
    pub cycles_per_mac_f64: f64,
    /// Estimated cycles per multiply-add of the interior-point method (f64): its iterations also divide,
    /// select and check element by element, work its multiply-add count leaves out.
    pub cycles_per_mac_ipm: f64,
    /// Estimated cycles per multiply-add of ADMM in f32: its iterations also clamp and update every
    /// row's z and y, work its multiply-add count leaves out.
    pub cycles_per_mac_admm: f64,
    /// The same with ADMM's x-update stage by stage ([`crate::solver::admm::Structure::Riccati`]): straight-line
    /// statements over one scratch array, fewer instructions a multiply-add than the dense factor's
    /// triangular solves.
    pub cycles_per_mac_admm_stages: f64,
    /// Estimated cycles per instruction (the emulated boards count instructions; `plan::target`'s table
    /// says where each figure comes from): 1.5 on the A9, 1 on the M4F (a lower bound), 1 on the host.
    pub cycles_per_instruction: f64,
    /// Estimated cycles per unit of the dual active-set method's cost model: a multiply-add of its
    /// factor's loops, a tenth of its work (`solver::active_set::Macs::work`, the multiply-adds and
    /// scanned rows weighed by their cost), which its budgets of work cap
    /// (`solver::active_set::method`'s `macs_per_step`), in the scalar it runs in on this machine (f32
    /// on the Cortex-M4F, f64 on the A9; the A9's f32 is taken as the same: VFP's single and double
    /// instructions count alike and the kernel uses no NEON). Set from the boards: the sampled
    /// certificate's heaviest cold case of paper, paper-limits, quadcopter and hover replayed by
    /// `scripts/witness.sh --board zynq|netduinoplus2`, the largest instructions per unit of the four
    /// plus 10 %, times [`Machine::cycles_per_instruction`].
    pub cycles_per_mac_active_set: f64,
}

/// The building machine: f64 in hardware, no SIMD assumed, no fixed clock. Its cycles per multiply-add
/// (one, either scalar) only rank choices: `cargo bench -p mpc-tests --bench constrained` measured the
/// emitted interior-point method at 2.4 multiply-adds a nanosecond on this project's 2-3 GHz Zen 3.
pub const HOST: Machine = Machine {
    target: Target::Host,
    processor: "the building machine",
    f64_in_hardware: true,
    simd: Simd::None,
    clock_hz: None,
    cycles_per_mac_f32: 1.0,
    cycles_per_mac_f64: 1.0,
    cycles_per_mac_ipm: 1.0,
    cycles_per_mac_admm: 1.0,
    cycles_per_mac_admm_stages: 1.0,
    cycles_per_instruction: 1.0,
    // The A9's figure over its interior-point one (42.7 / 10.3), so that `auto` ranks the active set
    // against the interior-point method on the host as on the A9: its unit, a multiply-add of the
    // factor's loops, is several instructions more than the others' multiply-adds.
    cycles_per_mac_active_set: 4.1,
};

/// The Zynq-7000's Cortex-A9: VFPv3 with 32 double registers (f64 in hardware) and NEON (f32 only). The
/// clock is 667 MHz, the fastest of the slowest speed grade (-1) in Xilinx's Zynq-7000 data sheet (DS190)
/// and that of the common XC7Z020-1 boards; the paper (Trinh et al., "Enhancing real-time drone trajectory
/// tracking performance using model predictive control on FPGA-SoC") does not state its clock.
pub const CORTEX_A9: Machine = Machine {
    target: Target::CortexA9,
    processor: "the Zynq-7000's Cortex-A9",
    f64_in_hardware: true,
    simd: Simd::Neon,
    clock_hz: Some(667e6),
    cycles_per_mac_f32: 1.2,
    cycles_per_mac_f64: 5.4,
    cycles_per_mac_ipm: 10.3,
    cycles_per_mac_admm: 6.6,
    cycles_per_mac_admm_stages: 4.8,
    cycles_per_instruction: 1.5,
    // 28.5 instructions a multiply-add of the factor's loops (a tenth of the work) × 1.5: at the
    // heaviest cold cases paper-limits 25.9, hover 25.8, quadcopter 25.3, paper (f32) 24.9, plus 10 %
    // (BENCHMARKS.md, "The worst cold case on the boards").
    cycles_per_mac_active_set: 42.7,
};

/// The STM32F405's Cortex-M4F: a single-precision FPU (FPv4-SP), no SIMD for floats (the M4's SIMD is
/// integer), 168 MHz at most (ST's STM32F405 data sheet).
pub const CORTEX_M4F: Machine = Machine {
    target: Target::CortexM4f,
    processor: "the STM32F405's Cortex-M4F",
    f64_in_hardware: false,
    simd: Simd::None,
    clock_hz: Some(168e6),
    cycles_per_mac_f32: 2.8,
    cycles_per_mac_f64: 163.0,
    cycles_per_mac_ipm: 311.0,
    cycles_per_mac_admm: 4.0,
    cycles_per_mac_admm_stages: 3.0,
    cycles_per_instruction: 1.0,
    // f32, 32.6 instructions a multiply-add of the factor's loops (a tenth of the work) × 1: at the
    // heaviest cold cases paper 29.6, paper-limits 28.5, hover 28.0, quadcopter 27.8, plus 10 %
    // (BENCHMARKS.md, "The worst cold case on the boards").
    cycles_per_mac_active_set: 32.6,
};

/// What the compiler knows of `target`.
pub const fn machine(target: Target) -> &'static Machine {
    match target {
        Target::Host => &HOST,
        Target::CortexA9 => &CORTEX_A9,
        Target::CortexM4f => &CORTEX_M4F,
    }
}

impl Machine {
    /// Estimated cycles per multiply-add in `scalar`.
    pub fn cycles_per_mac(&self, scalar: Scalar) -> f64 {
        match scalar {
            Scalar::F32 => self.cycles_per_mac_f32,
            Scalar::F64 => self.cycles_per_mac_f64,
        }
    }

    /// Estimated cycles of `macs` multiply-adds in `scalar`.
    pub fn cycles(&self, macs: usize, scalar: Scalar) -> f64 {
        macs as f64 * self.cycles_per_mac(scalar)
    }

    /// Cycles in a sampling period of `dt` seconds at the nominal clock; `None` without a fixed clock.
    pub fn period_cycles(&self, dt: f64) -> Option<f64> {
        self.clock_hz.map(|hz| hz * dt)
    }
}
