//! The `femto` command: flag parsing and glue. Every algorithm lives in the library.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    cli::reset_sigpipe();
    let args = match cli::parse_args() {
        Ok(args) => args,
        Err(code) => return code,
    };
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => cli::report(&e),
    }
}
