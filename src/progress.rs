//! Progress reporting for long stages, independent of the terminal.
//!
//! A `Progress` is a tracing span that the binary's `tracing-indicatif` layer draws as a bar
//! (hidden with `-q`, when stderr is not a terminal, and in tests, where no layer is
//! installed). Library code only calls `inc` in batches: a per-item call costs seconds over
//! millions of points, a call every few thousand items costs nothing.

use indicatif::ProgressStyle;
use tracing::Span;
use tracing_indicatif::span_ext::IndicatifSpanExt;

/// How many items to process between two bar updates in per-point loops.
pub const BATCH: usize = 4096;

/// A progress bar for one stage; cheap to clone into rayon workers.
#[derive(Clone)]
pub struct Progress {
    span: Span,
}

impl Progress {
    /// Starts a bar named `stage` that goes to `len` (in `unit`s, e.g. "points").
    pub fn start(stage: &'static str, len: u64, unit: &'static str) -> Self {
        let span = tracing::info_span!("progress", indicatif.pb_show = true, stage);
        let template = format!(
            "{{span_child_prefix}}{stage:>10} [{{bar:30}}] {{human_pos}}/{{human_len}} {unit} {{elapsed}} (eta {{eta}})"
        );
        if let Ok(style) = ProgressStyle::with_template(&template) {
            span.pb_set_style(&style.progress_chars("=> "));
        }
        span.pb_set_length(len);
        span.pb_start();
        Progress { span }
    }

    /// A bar that draws nothing (for callers that have no stage to show).
    pub fn hidden() -> Self {
        Progress { span: Span::none() }
    }

    /// Advances the bar by `n` items.
    pub fn inc(&self, n: u64) {
        self.span.pb_inc(n);
    }

    /// Sets the bar's length when it is only known after starting (e.g. after a header).
    pub fn set_len(&self, len: u64) {
        self.span.pb_set_length(len);
    }
}
