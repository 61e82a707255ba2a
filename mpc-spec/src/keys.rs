//! The spec's key names, in one place (serde's `symbol.rs`).

/// `[model]`.
pub const MODEL: &str = "model";
/// `[mpc]`.
pub const MPC: &str = "mpc";
/// `[kalman]`.
pub const KALMAN: &str = "kalman";
/// `[codegen]`.
pub const CODEGEN: &str = "codegen";

/// The tables a spec may have.
pub const TABLES: &[&str] = &[MODEL, MPC, KALMAN, CODEGEN];

/// Keys of `[model]`.
pub const MODEL_KEYS: &[&str] = &["type", "axes", "dt", "time", "a", "b", "c"];
/// Keys of `[mpc]`.
pub const MPC_KEYS: &[&str] = &[
    "horizon",
    "iterations",
    "tolerance",
    "strict",
    "accept_unstable",
    "method",
    "step",
    "q",
    "r",
    "qf",
    "qf_scale",
    "outputs",
    "r_du",
    "u_min",
    "u_max",
];
/// Keys of `[kalman]`.
pub const KALMAN_KEYS: &[&str] = &[
    "sigma_a",
    "sigma_meas",
    "q",
    "r",
    "p0",
    "filter",
    "disturbance",
    "gate",
    "stuck_cycles",
    "reacquire_after",
];
/// Keys of `[codegen]`.
pub const CODEGEN_KEYS: &[&str] = &["scalar", "emission"];

/// Values of `[model] type`.
pub const MODEL_TYPES: &[&str] = &["double_integrator", "linear"];
/// Values of `[model] time`.
pub const TIMES: &[&str] = crate::TimeDomain::NAMES;
/// Values of `[mpc] method`.
pub const METHODS: &[&str] = crate::Method::NAMES;
/// Values of `[kalman] filter`.
pub const FILTERS: &[&str] = crate::FilterKind::NAMES;
/// Values of `[codegen] scalar`.
pub const SCALARS: &[&str] = crate::Scalar::NAMES;
/// Values of `[codegen] emission`.
pub const EMISSIONS: &[&str] = crate::Emission::NAMES;
