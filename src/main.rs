//! The `radiosity` command line (DESIGN.md, "Command line"). Thin: each subcommand parses its
//! arguments and calls a library function; every error leaves as one `error: …` line on stderr
//! and exit status 1.

mod inspect;
mod view_factors;

use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(name = "radiosity", version, about = "Precomputed-transfer radiosity: bake once, light every frame with one mat-vec")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Object-to-object view factors of an OBJ scene, from its full-detail geometry.
    ViewFactors {
        /// The OBJ file.
        scene: PathBuf,
        /// Print JSON: {"objects", "areas", "matrix"}.
        #[arg(long)]
        json: bool,
    },
    /// Print what a .rad file holds: sizes, format, order, error estimates.
    Inspect {
        /// The .rad file.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
    },
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = match cli.command {
        Command::ViewFactors { scene, json } => view_factors::run(&scene, json),
        Command::Inspect { file, json } => inspect::run(&file, json),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined, never a backtrace.
            let msg: Vec<String> = e.chain().map(|c| c.to_string()).collect();
            eprintln!("error: {}", msg.join(": "));
            ExitCode::FAILURE
        }
    }
}
