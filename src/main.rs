//! The `femto` command: flag parsing and glue. Every algorithm lives in the library.

mod cli;

use std::process::ExitCode;

fn main() -> ExitCode {
    cli::reset_sigpipe();
    let args = match cli::parse_args() {
        Ok(args) => args,
        Err(code) => return code,
    };
    // A SIMD path forced with FEMTO_SIMD that is unknown or that this CPU lacks: bad input.
    if let Err(e) = femto::geometry::simd_level::SimdLevel::from_env() {
        eprintln!("femto: error: {e}");
        return ExitCode::from(2);
    }
    // SIGINT and SIGTERM remove the command's temporary files and exit 130 and 143.
    if let Err(e) = femto::interrupt::install() {
        eprintln!("femto: warning: SIGINT and SIGTERM will not clean up: {e}");
    }
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => cli::report(&e),
    }
}
