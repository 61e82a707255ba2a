//! The sections of the emitted module that every part fills.

use proc_macro2::TokenStream;
use quote::quote;

/// The items of one part of the module (the MPC, the filter), by the section a reader meets them in.
#[derive(Default)]
pub struct Sections {
    /// Small public constants: dimensions and parameters.
    pub constants: TokenStream,
    /// The public types and their methods.
    pub api: TokenStream,
    /// The private functions they call.
    pub kernels: TokenStream,
    /// The constant tables, last.
    pub tables: TokenStream,
}

impl Sections {
    /// `self` with `other`'s items after its own, section by section.
    pub fn append(self, other: Sections) -> Sections {
        let (a, b) = (self, other);
        let (c1, c2, p1, p2) = (a.constants, b.constants, a.api, b.api);
        let (k1, k2, t1, t2) = (a.kernels, b.kernels, a.tables, b.tables);
        Sections {
            constants: quote!(#c1 #c2),
            api: quote!(#p1 #p2),
            kernels: quote!(#k1 #k2),
            tables: quote!(#t1 #t2),
        }
    }
}
