//! The `tetsim` command: parse arguments, set up logging, run, map errors to an exit code.

mod cli;

use std::process::ExitCode;

use clap::Parser;

fn main() -> ExitCode {
    quiet_on_broken_pipe();
    let args = cli::Cli::parse();
    cli::init_logging(&args);
    match cli::run(args) {
        Ok(code) => code,
        Err(error) => {
            let message = error.to_string();
            eprintln!("error: {message}");
            let mut source = error.source();
            while let Some(cause) = source {
                // Our errors print their cause in their own message (`path: what the OS said`):
                // say it once.
                let text = cause.to_string();
                if !message.contains(&text) {
                    eprintln!("  caused by: {text}");
                }
                source = cause.source();
            }
            ExitCode::FAILURE
        }
    }
}

/// `tetsim run 2>&1 | head -1`: once the reader has gone, printing fails with a broken pipe and
/// Rust's print macros panic. Leave quietly instead, with the status a shell reports for a
/// process ended by SIGPIPE (128 + 13), as Unix tools do; any other panic is a bug and reported.
fn quiet_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let payload = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if payload.starts_with("failed printing to std") && payload.contains("os error 32") {
            std::process::exit(141);
        }
        default(info);
    }));
}
