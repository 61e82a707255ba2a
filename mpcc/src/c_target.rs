//! `mpcc emit SPEC --c DIR`: the target of the C crate `codegen::c_api::write_crate` writes.

/// The rustc triple for the spec's `[codegen] target`, or `None` for the host.
pub(crate) fn default_triple(target: mpc_spec::Target) -> Option<&'static str> {
    use mpc_spec::Target;
    match target {
        Target::CortexM4f => Some("thumbv7em-none-eabihf"),
        Target::CortexA9 => Some("armv7a-none-eabihf"),
        Target::Host => None,
    }
}
