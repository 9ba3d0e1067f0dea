//! The `sharpedge` binary: parse the command line, set up logs and progress bars, call the
//! library, print an error chain once and exit non-zero on failure.

mod cli;

use clap::Parser;
use tracing_indicatif::IndicatifLayer;
use tracing_indicatif::filter::{IndicatifFilter, hide_indicatif_span_fields};
use tracing_subscriber::fmt::format::DefaultFields;
use tracing_subscriber::layer::SubscriberExt;
use tracing_subscriber::util::SubscriberInitExt;
use tracing_subscriber::{EnvFilter, Layer};

fn init_logging(quiet: bool, verbose: u8) {
    use std::io::IsTerminal;
    // Colour codes only for a person at a terminal; batch logs (files, pipes) stay plain text.
    // NO_COLOR (https://no-color.org) still wins at a terminal.
    let ansi = std::io::stderr().is_terminal()
        && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty());
    let default = match (quiet, verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "warn,sharpedge=info",
        (false, 2) => "warn,sharpedge=debug",
        (false, _) => "trace",
    };
    let filter = EnvFilter::try_from_default_env().unwrap_or_else(|_| EnvFilter::new(default));
    if quiet {
        tracing_subscriber::registry()
            .with(
                tracing_subscriber::fmt::layer()
                    .with_writer(std::io::stderr)
                    .with_ansi(ansi)
                    .with_target(false)
                    .with_filter(filter),
            )
            .init();
        return;
    }
    let bars = IndicatifLayer::new()
        .with_span_field_formatter(hide_indicatif_span_fields(DefaultFields::new()));
    tracing_subscriber::registry()
        .with(
            tracing_subscriber::fmt::layer()
                .with_writer(bars.get_stderr_writer())
                .with_ansi(ansi)
                .with_target(false)
                .with_filter(filter),
        )
        .with(bars.with_filter(IndicatifFilter::new(false)))
        .init();
}

fn main() -> std::process::ExitCode {
    let cli = cli::Cli::parse();
    init_logging(cli.quiet, cli.verbose);
    match cli::dispatch(&cli) {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
