//! Rendering located diagnostics as rustc and cargo do (annotate-snippets): the one renderer behind the
//! macro's errors and the command line's.

use annotate_snippets::{Level, Renderer, Snippet};
use mpc_spec::{Diagnostic, Diagnostics};

/// Every diagnostic of `diags` drawn against `source`, which was read from `origin`.
pub fn render(diags: &Diagnostics, source: &str, origin: &str) -> String {
    diags
        .iter()
        .map(|d| render_one(d, source, origin))
        .collect::<Vec<_>>()
        .join("\n\n")
}

/// One error drawn against `source`.
pub fn render_one(d: &Diagnostic, source: &str, origin: &str) -> String {
    render_at(Level::Error, d, source, origin)
}

/// One warning drawn against `source`.
pub fn render_warning(d: &Diagnostic, source: &str, origin: &str) -> String {
    render_at(Level::Warning, d, source, origin)
}

fn render_at(level: Level, d: &Diagnostic, source: &str, origin: &str) -> String {
    let label = d.label.as_deref().unwrap_or_default();
    let mut message = level.title(&d.message);
    if let Some(span) = d.span.clone() {
        let mut snippet = Snippet::source(source)
            .origin(origin)
            .fold(true)
            .annotation(level.span(visible(&span, source)).label(label));
        // The other places it involves, drawn as rustc draws a secondary span.
        for (span, label) in &d.related {
            snippet = snippet.annotation(Level::Info.span(visible(span, source)).label(label));
        }
        message = message.snippet(snippet);
    }
    if let Some(note) = &d.note {
        message = message.footer(Level::Help.title(note.trim_start_matches("hint: ")));
    }
    Renderer::plain().render(message).to_string()
}

/// `span` inside `source`: an empty span (a missing table) is widened to one character so that the caret
/// shows; a whole character, as annotate-snippets panics on a range that ends inside one.
fn visible(span: &std::ops::Range<usize>, source: &str) -> std::ops::Range<usize> {
    let start = span.start.min(source.len());
    let next = source[start..].chars().next().map_or(0, char::len_utf8);
    start..span.end.max(start + next).min(source.len())
}
