//! Located diagnostics: every mistake in a spec is one [`Diagnostic`], and all are reported together.

use crate::model::Span;
use std::fmt;

/// One mistake in a spec, with where it was written.
#[derive(Clone, Debug, PartialEq)]
pub struct Diagnostic {
    /// What is wrong, lowercase, naming the key in backticks.
    pub message: String,
    /// The byte range of the offending key or value, when known.
    pub span: Option<Span>,
    /// A short label shown under the span.
    pub label: Option<String>,
    /// A hint on how to fix it.
    pub note: Option<String>,
    /// Other places the mistake involves, each with its label (drawn under the source like the span, as
    /// rustc draws a secondary span).
    pub related: Vec<(Span, String)>,
}

impl Diagnostic {
    /// A diagnostic at `span`.
    pub fn new(message: impl Into<String>, span: impl Into<Option<Span>>) -> Self {
        Diagnostic {
            message: message.into(),
            span: span.into(),
            label: None,
            note: None,
            related: Vec::new(),
        }
    }

    /// With a label under the span.
    pub fn label(mut self, label: impl Into<String>) -> Self {
        self.label = Some(label.into());
        self
    }

    /// With a hint.
    pub fn note(mut self, note: impl Into<String>) -> Self {
        self.note = Some(note.into());
        self
    }

    /// With another place it involves, labelled, when that place is known.
    pub fn related(mut self, span: Option<Span>, label: impl Into<String>) -> Self {
        if let Some(span) = span {
            self.related.push((span, label.into()));
        }
        self
    }

    /// Line and column (both 1-based) of the span's start in `source`.
    pub fn line_col(&self, source: &str) -> Option<(usize, usize)> {
        let start = self.span.as_ref()?.start.min(source.len());
        let before = &source[..start];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().map_or(0, |l| l.chars().count()) + 1;
        Some((line, col))
    }
}

impl fmt::Display for Diagnostic {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.message)?;
        if let Some(note) = &self.note {
            write!(f, " ({note})")?;
        }
        Ok(())
    }
}

/// Every diagnostic of one spec, in source order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Diagnostics(pub Vec<Diagnostic>);

impl Diagnostics {
    /// Adds a diagnostic.
    pub fn push(&mut self, d: Diagnostic) {
        self.0.push(d);
    }

    /// Whether there is none.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// The diagnostics sorted by position, unlocated ones last.
    pub fn sorted(mut self) -> Self {
        self.0
            .sort_by_key(|d| d.span.as_ref().map_or(usize::MAX, |s| s.start));
        self
    }

    /// The diagnostics.
    pub fn iter(&self) -> impl Iterator<Item = &Diagnostic> {
        self.0.iter()
    }
}

impl From<Diagnostic> for Diagnostics {
    fn from(d: Diagnostic) -> Self {
        Diagnostics(vec![d])
    }
}

impl fmt::Display for Diagnostics {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, d) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("\n")?;
            }
            write!(f, "{d}")?;
        }
        Ok(())
    }
}

impl std::error::Error for Diagnostics {}
