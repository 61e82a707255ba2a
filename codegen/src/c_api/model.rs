//! What the C API needs to know of an emitted module, parsed back from its tokens with `syn`.

use proc_macro2::TokenStream;
use std::collections::BTreeMap;
use syn::{Expr, Fields, FnArg, ImplItem, Item, ItemMod, Lit, Type};

/// A scalar C and Rust agree on (`bool` is C's `_Bool`, one byte with 0 or 1 on both sides).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Prim {
    /// `bool` / `bool` (stdbool.h).
    Bool,
    /// `u8` / `uint8_t`.
    U8,
    /// `u16` / `uint16_t`.
    U16,
    /// `u32` / `uint32_t`.
    U32,
    /// `u64` / `uint64_t`.
    U64,
    /// `i32` / `int32_t`.
    I32,
    /// `i64` / `int64_t`.
    I64,
    /// `f32` / `float`.
    F32,
    /// `f64` / `double`.
    F64,
}

impl Prim {
    fn from_ident(name: &str) -> Option<Prim> {
        Some(match name {
            "bool" => Prim::Bool,
            "u8" => Prim::U8,
            "u16" => Prim::U16,
            "u32" => Prim::U32,
            "u64" => Prim::U64,
            "i32" => Prim::I32,
            "i64" => Prim::I64,
            "f32" => Prim::F32,
            "f64" => Prim::F64,
            _ => return None,
        })
    }

    /// The Rust spelling.
    pub fn rust(self) -> &'static str {
        match self {
            Prim::Bool => "bool",
            Prim::U8 => "u8",
            Prim::U16 => "u16",
            Prim::U32 => "u32",
            Prim::U64 => "u64",
            Prim::I32 => "i32",
            Prim::I64 => "i64",
            Prim::F32 => "f32",
            Prim::F64 => "f64",
        }
    }

    /// The C spelling.
    pub fn c(self) -> &'static str {
        match self {
            Prim::Bool => "bool",
            Prim::U8 => "uint8_t",
            Prim::U16 => "uint16_t",
            Prim::U32 => "uint32_t",
            Prim::U64 => "uint64_t",
            Prim::I32 => "int32_t",
            Prim::I64 => "int64_t",
            Prim::F32 => "float",
            Prim::F64 => "double",
        }
    }

    /// Size and alignment in bytes (the same on every target the C API supports: 64-bit integers and
    /// `double` are 8-aligned on x86-64, AArch64 and the ARM EABI alike).
    pub fn size(self) -> usize {
        match self {
            Prim::Bool | Prim::U8 => 1,
            Prim::U16 => 2,
            Prim::U32 | Prim::I32 | Prim::F32 => 4,
            Prim::U64 | Prim::I64 | Prim::F64 => 8,
        }
    }
}

/// The C type of a status field.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum CType {
    /// A scalar.
    Prim(Prim),
    /// A fieldless Rust enum, as its discriminant in an `int32_t`; the name is the Rust enum's.
    Enum(String),
    /// Another status struct of the module, by its Rust name.
    Struct(String),
    /// `[T; len]`; `len_name` is the module constant that spells it (`NU`), if one does.
    Array {
        /// The element.
        elem: Box<CType>,
        /// The number of elements.
        len: usize,
        /// The constant the Rust type spells the length with, for the header's `PAPER_NU`.
        len_name: Option<String>,
    },
}

/// A field of a status struct.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Field {
    /// The Rust (and C) field name.
    pub name: String,
    /// Its type.
    pub ty: CType,
    /// Its rustdoc, one line per `///` line.
    pub doc: Vec<String>,
}

/// A status struct: `Status` and every struct its fields reach (`SolverStatus`, `FilterStatus`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Struct {
    /// The Rust name.
    pub name: String,
    /// Its rustdoc.
    pub doc: Vec<String>,
    /// The public fields in declaration order, which is the C order.
    pub fields: Vec<Field>,
}

/// A fieldless enum reached from a status struct.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Enum {
    /// The Rust name.
    pub name: String,
    /// Each variant with its discriminant and rustdoc.
    pub variants: Vec<(String, i64, Vec<String>)>,
}

/// Everything the header and the wrappers are written from.
#[derive(Clone, Debug, PartialEq)]
pub struct Model {
    /// The module's name, the prefix of every exported C name.
    pub name: String,
    /// `Real`: `F32` or `F64`.
    pub real: Prim,
    /// The module's `usize` constants (`NX`, `NU`, `NY`, `N`, ...), by name.
    pub consts: BTreeMap<String, usize>,
    /// Whether `Controller::new` and `reset` take the first state estimate `x0` (a filter's spec).
    pub takes_x0: bool,
    /// The measurement `step` takes: its parameter name and length constant (`z`, `NY` behind a
    /// filter; `x`, `NX` under state feedback).
    pub measured: (String, String),
    /// Whether `Controller::set_last_input` exists.
    pub set_last_input: bool,
    /// Whether `Controller::estimate` exists.
    pub estimate: bool,
    /// Whether `Status::fell_back` exists.
    pub fell_back: bool,
    /// The model matrices the module defines as `pub const NAME: [[Real; COLS]; ROWS]`, of those
    /// the C API hands out (`F`, `G`, and `C` behind a filter): name, rows and columns constants.
    pub matrices: Vec<(String, String, String)>,
    /// The `usize` constants of the module's `report` submodule (`MACS_PER_CYCLE`, ...), by name.
    pub report: BTreeMap<String, usize>,
    /// The status structs, each after the structs its fields use; `Status` is last.
    pub structs: Vec<Struct>,
    /// The enums the status structs use.
    pub enums: Vec<Enum>,
}

impl Model {
    /// Reads the model of the module `tokens` (`pub mod NAME { ... }`, as `Generated::tokens`). An error
    /// names what the C API cannot express, such as a status field of a type it has no C spelling for.
    pub fn from_module(tokens: &TokenStream) -> Result<Model, String> {
        let module: ItemMod = syn::parse2(tokens.clone())
            .map_err(|e| format!("the emitted module does not parse: {e}"))?;
        let name = module.ident.to_string();
        let items = module
            .content
            .as_ref()
            .map(|(_, items)| items.as_slice())
            .ok_or_else(|| format!("module `{name}` has no body"))?;

        let mut consts = BTreeMap::new();
        let mut real = None;
        let mut structs = BTreeMap::new();
        let mut enums = BTreeMap::new();
        let mut controller_fns = Vec::new();
        let mut fell_back = false;
        let mut matrices = Vec::new();
        let mut report = BTreeMap::new();
        for item in items {
            match item {
                Item::Const(c) if is_usize(&c.ty) => {
                    if let Some(v) = eval(&c.expr, &consts) {
                        consts.insert(c.ident.to_string(), v);
                    }
                }
                Item::Const(c) if MATRICES.contains(&c.ident.to_string().as_str()) => {
                    if let Some((rows, cols)) = real_matrix(&c.ty) {
                        matrices.push((c.ident.to_string(), rows, cols));
                    }
                }
                Item::Impl(i) if type_ident(&i.self_ty).as_deref() == Some("Status") => {
                    fell_back |= i
                        .items
                        .iter()
                        .any(|item| matches!(item, ImplItem::Fn(f) if f.sig.ident == "fell_back"));
                }
                Item::Mod(m) if m.ident == "report" => {
                    for item in m.content.iter().flat_map(|(_, items)| items) {
                        if let Item::Const(c) = item {
                            if is_usize(&c.ty) {
                                if let Some(v) = eval(&c.expr, &report) {
                                    report.insert(c.ident.to_string(), v);
                                }
                            }
                        }
                    }
                }
                Item::Type(t) if t.ident == "Real" => {
                    real = type_ident(&t.ty).and_then(|i| Prim::from_ident(&i));
                }
                Item::Struct(s) => {
                    structs.insert(s.ident.to_string(), s);
                }
                Item::Enum(e) => {
                    enums.insert(e.ident.to_string(), e);
                }
                Item::Impl(i) if type_ident(&i.self_ty).as_deref() == Some("Controller") => {
                    for item in &i.items {
                        if let ImplItem::Fn(f) = item {
                            controller_fns.push(&f.sig);
                        }
                    }
                }
                _ => {}
            }
        }
        let real = real
            .filter(|r| matches!(r, Prim::F32 | Prim::F64))
            .ok_or_else(|| format!("module `{name}` has no `type Real = f32` or `f64`"))?;
        for dim in ["NX", "NU", "N"] {
            if !consts.contains_key(dim) {
                return Err(format!("module `{name}` has no constant `{dim}: usize`"));
            }
        }
        let sig = |f: &str| controller_fns.iter().find(|s| s.ident == f).copied();
        let new = sig("new").ok_or_else(|| format!("`{name}::Controller` has no `new`"))?;
        let takes_x0 = new.inputs.len() == 1;
        let step = sig("step").ok_or_else(|| format!("`{name}::Controller` has no `step`"))?;
        let measured = match step.inputs.iter().nth(1) {
            Some(FnArg::Typed(arg)) => {
                let param = quote::ToTokens::to_token_stream(&arg.pat).to_string();
                let len = match &*arg.ty {
                    Type::Reference(r) => match &*r.elem {
                        Type::Array(a) => quote::ToTokens::to_token_stream(&a.len).to_string(),
                        _ => String::new(),
                    },
                    _ => String::new(),
                };
                if !consts.contains_key(&len) {
                    return Err(format!(
                        "`{name}::Controller::step` takes `{param}` of an unknown length `{len}`"
                    ));
                }
                (param, len)
            }
            _ => return Err(format!("`{name}::Controller::step` has no measurement")),
        };

        let mut model = Model {
            name: name.clone(),
            real,
            consts,
            takes_x0,
            measured,
            set_last_input: sig("set_last_input").is_some(),
            estimate: sig("estimate").is_some(),
            fell_back,
            matrices,
            report,
            structs: Vec::new(),
            enums: Vec::new(),
        };
        model.add_struct("Status", &structs, &enums)?;
        Ok(model)
    }

    /// Adds the struct `name` after the structs and enums its fields use.
    fn add_struct(
        &mut self,
        name: &str,
        structs: &BTreeMap<String, &syn::ItemStruct>,
        enums: &BTreeMap<String, &syn::ItemEnum>,
    ) -> Result<(), String> {
        if self.structs.iter().any(|s| s.name == name) {
            return Ok(());
        }
        let item = structs
            .get(name)
            .ok_or_else(|| format!("module `{}` has no struct `{name}`", self.name))?;
        let Fields::Named(named) = &item.fields else {
            return Err(format!("`{}::{name}` has no named fields", self.name));
        };
        let mut fields = Vec::new();
        for field in &named.named {
            if !matches!(field.vis, syn::Visibility::Public(_)) {
                continue;
            }
            let fname = field
                .ident
                .as_ref()
                .map(|i| i.to_string())
                .unwrap_or_default();
            let ty = self
                .c_type(&field.ty, structs, enums)
                .map_err(|why| format!("`{}::{name}::{fname}`: {why}", self.name))?;
            fields.push(Field {
                name: fname,
                ty,
                doc: docs(&field.attrs),
            });
        }
        self.structs.push(Struct {
            name: name.into(),
            doc: docs(&item.attrs),
            fields,
        });
        Ok(())
    }

    fn c_type(
        &mut self,
        ty: &Type,
        structs: &BTreeMap<String, &syn::ItemStruct>,
        enums: &BTreeMap<String, &syn::ItemEnum>,
    ) -> Result<CType, String> {
        let spelled = quote::ToTokens::to_token_stream(ty).to_string();
        match ty {
            Type::Array(a) => {
                let elem = self.c_type(&a.elem, structs, enums)?;
                let len = eval(&a.len, &self.consts)
                    .ok_or_else(|| format!("the length of `{spelled}` is not a known constant"))?;
                let len_name = match &a.len {
                    Expr::Path(p) => p.path.get_ident().map(|i| i.to_string()),
                    _ => None,
                };
                Ok(CType::Array {
                    elem: Box::new(elem),
                    len,
                    len_name,
                })
            }
            _ => {
                let ident = type_ident(ty)
                    .ok_or_else(|| format!("the type `{spelled}` has no C spelling"))?;
                if ident == "Real" {
                    return Ok(CType::Prim(self.real));
                }
                if let Some(p) = Prim::from_ident(&ident) {
                    return Ok(CType::Prim(p));
                }
                if let Some(e) = enums.get(&ident) {
                    self.add_enum(e)?;
                    return Ok(CType::Enum(ident));
                }
                if structs.contains_key(&ident) {
                    self.add_struct(&ident, structs, enums)?;
                    return Ok(CType::Struct(ident));
                }
                Err(format!("the type `{spelled}` has no C spelling"))
            }
        }
    }

    fn add_enum(&mut self, item: &syn::ItemEnum) -> Result<(), String> {
        let name = item.ident.to_string();
        if self.enums.iter().any(|e| e.name == name) {
            return Ok(());
        }
        let mut next = 0i64;
        let mut variants = Vec::new();
        for v in &item.variants {
            if !matches!(v.fields, Fields::Unit) {
                return Err(format!("`{}::{name}::{}` carries data", self.name, v.ident));
            }
            if let Some((_, expr)) = &v.discriminant {
                next = match expr {
                    Expr::Lit(l) => match &l.lit {
                        Lit::Int(i) => i.base10_parse().map_err(|e| e.to_string())?,
                        _ => {
                            return Err(format!(
                                "`{}::{name}`: a discriminant is not an integer",
                                self.name
                            ))
                        }
                    },
                    _ => {
                        return Err(format!(
                            "`{}::{name}`: a discriminant is not a literal",
                            self.name
                        ))
                    }
                };
            }
            variants.push((v.ident.to_string(), next, docs(&v.attrs)));
            next += 1;
        }
        self.enums.push(Enum { name, variants });
        Ok(())
    }

    /// Whether the module defines the matrix `name` as `[[Real; cols]; rows]`.
    pub fn has_matrix(&self, name: &str, rows: &str, cols: &str) -> bool {
        self.matrices
            .iter()
            .any(|(n, r, c)| n == name && r == rows && c == cols)
    }

    /// The value of the `usize` constant `name`.
    pub fn dim(&self, name: &str) -> usize {
        self.consts.get(name).copied().unwrap_or(0)
    }

    /// The struct named `name`.
    pub fn get_struct(&self, name: &str) -> Option<&Struct> {
        self.structs.iter().find(|s| s.name == name)
    }

    /// The enum named `name`.
    pub fn get_enum(&self, name: &str) -> Option<&Enum> {
        self.enums.iter().find(|e| e.name == name)
    }

    /// The C layout (size, alignment) of `ty`, by the C rules both `#[repr(C)]` and the C compiler follow.
    pub fn c_layout(&self, ty: &CType) -> (usize, usize) {
        match ty {
            CType::Prim(p) => (p.size(), p.size()),
            CType::Enum(_) => (4, 4),
            CType::Array { elem, len, .. } => {
                let (size, align) = self.c_layout(elem);
                (size * len, align)
            }
            CType::Struct(name) => self.struct_layout(name),
        }
    }

    /// The C layout (size, alignment) of the status struct `name`.
    pub fn struct_layout(&self, name: &str) -> (usize, usize) {
        let Some(s) = self.get_struct(name) else {
            return (0, 1);
        };
        let (mut size, mut align) = (0usize, 1usize);
        for f in &s.fields {
            let (fs, fa) = self.c_layout(&f.ty);
            size = size.next_multiple_of(fa) + fs;
            align = align.max(fa);
        }
        (size.next_multiple_of(align), align)
    }
}

/// The model matrices the C API hands out, when the module defines them over `Real` and its dimension
/// constants: the dynamics `F` (NX × NX), `G` (NX × NU), and the measurement `C` (NY × NX) of a filter.
const MATRICES: [&str; 3] = ["F", "G", "C"];

/// `[[Real; COLS]; ROWS]` spelled with two constants: their names.
fn real_matrix(ty: &Type) -> Option<(String, String)> {
    let Type::Array(outer) = ty else { return None };
    let Type::Array(inner) = &*outer.elem else {
        return None;
    };
    let ident = |e: &Expr| match e {
        Expr::Path(p) => p.path.get_ident().map(|i| i.to_string()),
        _ => None,
    };
    (type_ident(&inner.elem).as_deref() == Some("Real"))
        .then(|| Some((ident(&outer.len)?, ident(&inner.len)?)))
        .flatten()
}

fn is_usize(ty: &Type) -> bool {
    type_ident(ty).as_deref() == Some("usize")
}

/// The single identifier a type path is spelled with (`Real`, `u32`, `SolverStatus`).
fn type_ident(ty: &Type) -> Option<String> {
    match ty {
        Type::Path(p) if p.qself.is_none() => p.path.get_ident().map(|i| i.to_string()),
        _ => None,
    }
}

/// An integer constant expression over literals, known constants, `+`, `-` and `*`.
fn eval(expr: &Expr, consts: &BTreeMap<String, usize>) -> Option<usize> {
    match expr {
        Expr::Lit(l) => match &l.lit {
            Lit::Int(i) => i.base10_parse().ok(),
            _ => None,
        },
        Expr::Path(p) => consts.get(&p.path.get_ident()?.to_string()).copied(),
        Expr::Paren(p) => eval(&p.expr, consts),
        Expr::Binary(b) => {
            let (l, r) = (eval(&b.left, consts)?, eval(&b.right, consts)?);
            match b.op {
                syn::BinOp::Add(_) => l.checked_add(r),
                syn::BinOp::Sub(_) => l.checked_sub(r),
                syn::BinOp::Mul(_) => l.checked_mul(r),
                _ => None,
            }
        }
        _ => None,
    }
}

/// The `///` lines of `attrs`, trimmed.
fn docs(attrs: &[syn::Attribute]) -> Vec<String> {
    attrs
        .iter()
        .filter(|a| a.path().is_ident("doc"))
        .filter_map(|a| match &a.meta {
            syn::Meta::NameValue(nv) => match &nv.value {
                Expr::Lit(syn::ExprLit {
                    lit: Lit::Str(s), ..
                }) => Some(s.value().trim().to_string()),
                _ => None,
            },
            _ => None,
        })
        .collect()
}
