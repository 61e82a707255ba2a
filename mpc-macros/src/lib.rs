#![doc = include_str!("../README.md")]

use codegen::{Opt, Origin};
use proc_macro::TokenStream;
use quote::ToTokens;
use syn::parse::{Parse, ParseStream};
use syn::{braced, parse_macro_input, Ident, LitStr, Token, Visibility};

/// `vis mod name = "path/to/spec.toml"` or `vis mod name { "spec text" }`.
struct Input {
    vis: Visibility,
    name: Ident,
    spec: LitStr,
    inline: bool,
}

impl Parse for Input {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let vis = input.parse()?;
        input.parse::<Token![mod]>()?;
        let name = input.parse()?;
        let (spec, inline) = if input.peek(Token![=]) {
            input.parse::<Token![=]>()?;
            (input.parse()?, false)
        } else if input.peek(syn::token::Brace) {
            let body;
            braced!(body in input);
            let spec = body.parse()?;
            if !body.is_empty() {
                return Err(body.error("expected only the spec text inside the braces"));
            }
            (spec, true)
        } else {
            return Err(input.error(
                "expected `= \"path/to/spec.toml\"` or `{ \"spec text\" }` after the module name",
            ));
        };
        input.parse::<Option<Token![;]>>()?;
        Ok(Input {
            vis,
            name,
            spec,
            inline,
        })
    }
}

/// Compiles a controller spec into a module; see the crate docs for the two forms.
#[proc_macro]
pub fn mpc(input: TokenStream) -> TokenStream {
    let input = parse_macro_input!(input as Input);
    expand(&input)
        .unwrap_or_else(syn::Error::into_compile_error)
        .into()
}

fn expand(input: &Input) -> syn::Result<proc_macro2::TokenStream> {
    let (source, origin, shown) = if input.inline {
        (
            input.spec.value(),
            Origin::Inline,
            "<inline spec>".to_string(),
        )
    } else {
        let written = input.spec.value();
        let dir = std::env::var("CARGO_MANIFEST_DIR").unwrap_or_else(|_| ".".into());
        let path = std::path::Path::new(&dir).join(&written);
        // A FIFO, a device or a directory is refused before it is opened, and a file is read to at most
        // codegen::input::SPEC_SIZE_LIMIT: a build never hangs or reads without bound here (as `mpcc`).
        let source = codegen::input::read_file(&path).map_err(|e| {
            syn::Error::new(
                input.spec.span(),
                format!("cannot read the spec `{}`: {e}", path.display()),
            )
        })?;
        let absolute = path.to_string_lossy().into_owned();
        (
            source,
            Origin::File {
                written: written.clone(),
                absolute,
            },
            written,
        )
    };
    let opt = Opt::new(
        input.name.to_string(),
        input.vis.to_token_stream().to_string(),
        origin,
    );
    let generated = codegen::generate_from_source(&source, &opt).map_err(|diags| {
        let rendered = codegen::render::render(&diags, &source, &shown);
        syn::Error::new(
            input.spec.span(),
            format!("invalid controller spec\n{rendered}"),
        )
    })?;
    // Stable proc macros cannot emit warnings. Using a `#[deprecated]` item does make rustc print one,
    // and the span of the spec literal points it at the user's code. Each lives in an anonymous const of
    // its own, so that the warnings of several `mpc!` in one module do not collide.
    let warnings = generated.warnings.iter().map(|w| {
        let note = format!(
            "controller spec warning\n{}",
            codegen::render::render_warning(w, &source, &shown)
        );
        let name = quote::format_ident!("__mpc_spec_warning", span = input.spec.span());
        quote::quote_spanned! {input.spec.span()=>
            const _: () = {
                #[deprecated(note = #note)]
                #[allow(non_upper_case_globals)]
                const #name: () = ();
                #name
            };
        }
    });
    let tokens = generated.tokens;
    Ok(quote::quote! {
        #tokens
        #(#warnings)*
    })
}
