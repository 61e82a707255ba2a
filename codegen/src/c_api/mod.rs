//! The C API of a generated controller (`mpcc emit SPEC --c DIR`): a header `NAME.h`, a C++ header
//! `NAME.hpp` over it, and the `extern "C"` wrappers of a `staticlib` crate, all written from one
//! [`Model`] of the emitted module.
//!
//! The model is read back from the emitted module itself ([`Model::from_module`]), not from the emitter's
//! inputs: the C status structs list exactly the fields the Rust `Status`, `SolverStatus` and
//! `FilterStatus` have, so a field added to the emitter appears in C without an edit here.

mod cpp;
mod header;
mod krate;
mod model;
mod wrapper;

pub use cpp::header_hpp;
pub use header::header;
pub use krate::write_crate;
pub use model::{CType, Field, Model, Prim, Struct};
pub use wrapper::lib_rs;

/// The size and alignment in bytes of the Rust `Controller`, which C allocates as opaque bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// `size_of::<Controller>()`.
    pub size: usize,
    /// `align_of::<Controller>()`.
    pub align: usize,
}
