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
    "control_horizon",
    "move_blocking",
    "iterations",
    "tolerance",
    "strict",
    "accept_unstable",
    "method",
    "step",
    "admm_form",
    "restart",
    "q",
    "r",
    "qf",
    "qf_scale",
    "outputs",
    "r_du",
    "u_min",
    "u_max",
    "x_min",
    "x_max",
    "x_soft",
    "x_backoff",
    "du_min",
    "du_max",
    CONSTRAINT,
    "accuracy",
    REGION,
];
/// `[[mpc.constraint]]`: a group of rows lower ≤ Ax·x_k + Au·u_k ≤ upper, an array of tables in `[mpc]`.
pub const CONSTRAINT: &str = "constraint";
/// Keys of each `[[mpc.constraint]]`.
pub const CONSTRAINT_KEYS: &[&str] = &["ax", "au", "lower", "upper", "soft", "backoff"];
/// `[mpc.region]`: where the compiler certifies an interior-point method, a table in `[mpc]`.
pub const REGION: &str = "region";
/// Keys of `[mpc.region]`.
pub const REGION_KEYS: &[&str] = &[
    "x_min",
    "x_max",
    "reference_min",
    "reference_max",
    "samples",
    "sequences",
    "steps",
    "certificate",
    "exact_lps",
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
pub const CODEGEN_KEYS: &[&str] = &["scalar", "emission", "target", "clock_hz"];

/// Values of `[model] type`.
pub const MODEL_TYPES: &[&str] = &["double_integrator", "linear"];
/// Values of `[model] time`.
pub const TIMES: &[&str] = crate::TimeDomain::NAMES;
/// Values of `[mpc] method`.
pub const METHODS: &[&str] = crate::Method::NAMES;
/// Spellings of `[mpc] admm_form`: `auto` (the certificate's choice) or an [`crate::AdmmForm`].
pub const ADMM_FORMS: &[&str] = &["auto", "direct", "residual"];
/// Values of `[mpc] restart`.
pub const RESTARTS: &[&str] = crate::Restart::NAMES;
/// Values of `[mpc.region] certificate`.
pub const CERTIFICATES: &[&str] = crate::Certificate::NAMES;
/// Values of `[kalman] filter`.
pub const FILTERS: &[&str] = crate::FilterKind::NAMES;
/// Values of `[codegen] scalar`.
pub const SCALARS: &[&str] = crate::Scalar::NAMES;
/// Values of `[codegen] emission`.
pub const EMISSIONS: &[&str] = crate::Emission::NAMES;
/// Values of `[codegen] target`.
pub const TARGETS: &[&str] = crate::Target::NAMES;
