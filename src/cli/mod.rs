//! The native command line. `strahler` with no subcommand opens the app window.

mod info;

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// Strahler: hydrology-based terrain synthesis.
#[derive(Debug, Parser)]
#[command(name = "strahler", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Print the version, the GPU adapter found and the limits that matter.
    Info(info::InfoArgs),
}

/// Runs a subcommand and maps its outcome to an exit code (errors go to stderr).
pub fn run(command: Command) -> ExitCode {
    let result = match command {
        Command::Info(args) => info::run(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err}");
            ExitCode::FAILURE
        }
    }
}
