//! The `relief` command-line tool: terrain algorithms from `relief-core` on real elevation data.
//!
//! Every subcommand prints human-readable text, or one JSON object with `--json`. Every failure
//! prints a single line `relief: error: ...` on stderr and exits with code 2.
#![deny(missing_docs)]

mod args;
mod cmd;

use clap::{Parser, Subcommand};
use std::io::Write;
use std::process::ExitCode;

/// Terrain algorithms on real elevation data.
#[derive(Debug, Parser)]
#[command(name = "relief", version, about, max_term_width = 100)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Debug diagrams of what the algorithms did (refine, dda, silhouette, rbf, cascades) as PNG.
    Diagram(cmd::diagram::DiagramArgs),
    /// Print size and height statistics of a DEM.
    Info(cmd::info::InfoArgs),
    /// SOAR refinement of a DEM into an OBJ mesh (view-independent or view-dependent).
    Mesh(cmd::mesh::MeshArgs),
    /// Run every method on one DEM: accuracy against time, as HTML, Markdown, JSON and PNGs.
    Report(cmd::report::ReportArgs),
    /// Adaptive grid + truncated Gaussian RBF approximation of a DEM (cells CSV, raw f32).
    Rbf(cmd::rbf::RbfArgs),
    /// Ray trace a DEM from a camera into a depth image (cell-dda, run-dda, maxmip, march).
    Trace(cmd::trace::TraceArgs),
    /// Render a DEM to PNG on the GPU or CPU with named effects (lighting, shadows, fog, ...).
    Render(cmd::render::RenderArgs),
}

/// A failure to report: one line, exit code 2.
#[derive(Debug)]
pub struct CliError(pub String);

impl<E: std::fmt::Display> From<E> for CliError {
    fn from(e: E) -> Self {
        CliError(e.to_string())
    }
}

/// Result of a subcommand.
pub type CliResult<T = ()> = Result<T, CliError>;

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                let _ = e.print();
                return ExitCode::SUCCESS;
            }
            if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                eprintln_safe("relief: error: no subcommand given (see relief --help)");
                return ExitCode::from(2);
            }
            // Clap's message runs until the first blank line (then usage and hints follow);
            // fold it into one line.
            let text = e.to_string();
            let first: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let first = first.join(" ");
            let first = first.trim_start_matches("error: ");
            eprintln_safe(&format!("relief: error: {first} (see relief --help)"));
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Diagram(a) => cmd::diagram::run(&a),
        Command::Info(a) => cmd::info::run(&a),
        Command::Mesh(a) => cmd::mesh::run(&a),
        Command::Report(a) => cmd::report::run(&a),
        Command::Rbf(a) => cmd::rbf::run(&a),
        Command::Trace(a) => cmd::trace::run(&a),
        Command::Render(a) => cmd::render::run(&a),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(CliError(msg)) => {
            let one_line = msg.split_whitespace().collect::<Vec<_>>().join(" ");
            eprintln_safe(&format!("relief: error: {one_line}"));
            ExitCode::from(2)
        }
    }
}

/// Writes a line to stderr, ignoring a closed stream (never panics).
fn eprintln_safe(line: &str) {
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// Writes text to stdout; a closed pipe is not an error worth a panic.
pub fn print_out(text: &str) -> CliResult {
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|()| out.flush()) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => Ok(()),
        Err(e) => Err(CliError(format!("cannot write to stdout: {e}"))),
    }
}
