//! The `moldgate` command: parses arguments, reads files, calls the library, prints.
//!
//! Exit codes (also in docs/cli.md):
//! 0 success; 1 unexpected internal error; 2 invalid command line or option value;
//! 3 input file missing, unreadable or malformed; 4 no node qualifies for a gate;
//! 5 output cannot be written.

#[cfg(target_os = "linux")]
mod alloc;
mod analyse;
mod args;
mod batch;
mod deadline;
mod formats;
mod glb;
mod locate;
mod materials;
mod output;
mod pictures;
mod progress;
mod sample;
mod serve;
mod summary;
mod toml_file;

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;

use args::{Cli, Command};

/// Large blocks on huge pages (see `alloc.rs`); elsewhere the system allocator as it is.
#[cfg(target_os = "linux")]
#[global_allocator]
static ALLOCATOR: alloc::Allocator = alloc::Allocator;

/// An error with the exit code it maps to.
#[derive(Debug)]
pub struct Failure {
    /// Process exit code.
    pub code: u8,
    /// One line for stderr.
    pub message: String,
    /// Whether the study was stopped at `--timeout` (exit code 6; a batch's row says
    /// `timeout`).
    pub timed_out: bool,
    /// What a study stopped in its fill stage found before the stop (see
    /// [`moldgate::StudyError::Cancelled`]): a batch's row gives its gate.
    pub located: Option<Box<moldgate::report::Report>>,
}

impl Failure {
    /// A failure with exit code `code` (1 internal error, 2 option, 3 input, 4 no gate,
    /// 5 output, 6 stopped at `--timeout`).
    pub fn new(code: u8, message: impl Into<String>) -> Failure {
        Failure {
            code,
            message: message.into(),
            timed_out: false,
            located: None,
        }
    }

    /// Invalid command line or option value.
    pub fn usage(message: impl Into<String>) -> Failure {
        Failure::new(2, message)
    }

    /// A study stopped at `--timeout`: exit code 6, apart from a bad option's 2, so that a
    /// pipeline can tell a part worth trying again with more time from a command to fix.
    pub fn timeout(message: impl Into<String>) -> Failure {
        Failure {
            timed_out: true,
            ..Failure::new(6, message)
        }
    }

    /// Unreadable or malformed input.
    pub fn input(message: impl Into<String>) -> Failure {
        Failure::new(3, message)
    }

    /// No gate could be placed.
    pub fn no_gate(message: impl Into<String>) -> Failure {
        Failure::new(4, message)
    }

    /// Output cannot be written.
    pub fn output(message: impl Into<String>) -> Failure {
        Failure::new(5, message)
    }
}

/// Rust's words for a number that does not parse, in clap's message of an option's value,
/// as a person says them: "invalid digit found in string" is "expected a whole number".
fn plain_parse_words(message: &str) -> String {
    let mut m = message.to_string();
    // A negative count: "invalid value '-1' for '--gates <K>': invalid digit found in string".
    let negative = message
        .split('\'')
        .nth(1)
        .and_then(|v| v.parse::<f64>().ok())
        .is_some_and(|v| v < 0.0);
    if negative {
        m = m.replace(
            "invalid digit found in string",
            "expected a whole number, not a negative one",
        );
    }
    for (rust, plain) in [
        ("invalid digit found in string", "expected a whole number"),
        (
            "cannot parse integer from empty string",
            "expected a whole number",
        ),
        (
            "number too large to fit in target type",
            "a whole number too large",
        ),
        (
            "number too small to fit in target type",
            "a whole number too small",
        ),
        ("invalid float literal", "expected a number"),
        ("cannot parse float from empty string", "expected a number"),
    ] {
        m = m.replace(rust, plain);
    }
    // clap's range of a count: "0 is not in 1..=1024".
    if let Some(at) = m.find(" is not in ") {
        let range = &m[at + " is not in ".len()..];
        if let Some((low, high)) = range.split_once("..=") {
            let value = m[..at].rsplit(": ").next().unwrap_or_default().to_string();
            let head = &m[..at - value.len()];
            m = format!("{head}expected a whole number from {low} to {high}, got {value}");
        }
    }
    m
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version, on stdout: a stdout that cannot take them (a full disk,
            // /dev/full) is an output error, as for every other command.
            return match output::print_stdout(&e.render().to_string()) {
                Ok(()) => ExitCode::SUCCESS,
                Err(f) => {
                    let _ = writeln!(std::io::stderr(), "moldgate: error: {}", f.message);
                    ExitCode::from(f.code)
                }
            };
        }
        Err(e) if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            let _ = e.print();
            return ExitCode::from(2);
        }
        Err(e) => {
            // Clap's message, on one line: its first line, less clap's own prefix.
            let text = e.to_string();
            let mut first = text
                .lines()
                .next()
                .unwrap_or("invalid command line")
                .trim_start_matches("error: ")
                .to_string();
            first = plain_parse_words(&first);
            // A list after the colon (the missing arguments) goes on the same line.
            if first.ends_with(':') {
                let items: Vec<&str> = text
                    .lines()
                    .skip(1)
                    .map(str::trim)
                    .take_while(|l| !l.is_empty())
                    .collect();
                first = format!("{first} {}", items.join(", "));
            }
            let _ = writeln!(
                std::io::stderr(),
                "moldgate: error: {first} (see moldgate --help)"
            );
            return ExitCode::from(2);
        }
    };
    // A signal that ends the run removes the temporary files of its outputs. The service
    // writes no files and stops on SIGTERM and Ctrl-C by itself, after the requests in
    // flight.
    if !matches!(cli.command, Command::Serve(_)) {
        output::clean_up_on_signals();
    }
    // A panic is a bug: report it on one line with exit code 1, not Rust's 101.
    std::panic::set_hook(Box::new(|info| {
        let _ = writeln!(
            std::io::stderr(),
            "moldgate: error: internal error, please report it: {info}"
        );
    }));
    let result = std::panic::catch_unwind(|| match cli.command {
        Command::Locate(a) => locate::run_locate(*a),
        Command::Sample(a) => sample::run_sample(a),
        Command::Materials(a) => materials::run_materials(a),
        Command::Serve(a) => serve::run_serve(a),
    });
    let Ok(result) = result else {
        return ExitCode::from(1);
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            // An empty message: the lines were printed already (a batch's end report).
            if !f.message.is_empty() {
                let _ = writeln!(
                    std::io::stderr(),
                    "moldgate: error: {}",
                    printable(&f.message)
                );
            }
            ExitCode::from(f.code)
        }
    }
}

/// Whether a character is escaped in a message: a control character (a line break, a
/// terminal escape) or a bidirectional formatting mark (U+202E would print the rest of the
/// line reversed).
fn escaped_in_messages(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200e}' | '\u{200f}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// `text` with its control characters and bidirectional marks escaped (`\n`, `\u{1b}`,
/// `\u{202e}`): a message is one line and quotes file names and options as given, and a
/// name holding a line break or a terminal escape must not reach the terminal as one.
pub fn printable(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(escaped_in_messages) {
        return text.into();
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        if escaped_in_messages(c) {
            out.extend(c.escape_default());
        } else {
            out.push(c);
        }
    }
    out.into()
}
