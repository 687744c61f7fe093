//! The `radiosity` command line (DESIGN.md, "Command line"). Thin: each subcommand parses its
//! arguments and calls a library function; every error leaves as one `error: …` line on stderr
//! and a non-zero exit status.

/// `print!`/`println!` for command output: a closed pipe (`radiosity … | head`) ends the
/// program quietly with status 0 instead of panicking; any other write error is a one-line error.
macro_rules! out {
    ($($t:tt)*) => { $crate::write_stdout(format_args!($($t)*), false) };
}
macro_rules! outln {
    ($($t:tt)*) => { $crate::write_stdout(format_args!($($t)*), true) };
}

mod args;
mod backend;
mod bake;
mod bench;
mod camera;
mod check_rows;
mod demo;
mod embedded;
mod export_dds;
mod inspect;
mod lights;
mod pathtrace;
mod picture;
mod progress;
mod render;
mod report;
mod runtime;
mod solve;
mod view_factors;

use args::BakeArgs;
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "radiosity",
    version,
    about = "Precomputed-transfer radiosity: bake once, light every frame with one mat-vec"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bake the embedded Cornell box and light it: writes demo.png, demo.gif and demo.rad.
    Demo {
        /// Directory for demo.png, demo.gif and demo.rad.
        #[arg(long, default_value = ".")]
        out: PathBuf,
        /// Gather backend: auto, cpu, gpu or reference (default: $RADIOSITY_BACKEND, else auto).
        #[arg(long)]
        backend: Option<String>,
        /// Target patch count of the bake.
        #[arg(long, default_value_t = 2048)]
        patches: usize,
    },
    /// Bake an OBJ scene into a compressed transfer matrix (.rad).
    Bake {
        /// The OBJ file.
        scene: PathBuf,
        /// Where to write the .rad file (written atomically).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        bake: BakeArgs,
        /// Print the bake report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Light a scene (its emitters, plus analytic lights) and report per-object irradiance and radiosity.
    Solve {
        /// An OBJ scene (baked first, with the bake flags) or a .rad file.
        input: PathBuf,
        #[command(flatten)]
        bake: BakeArgs,
        /// Analytic lights (JSON: point, spot, directional) added to the scene's emitters.
        #[arg(long, value_name = "LIGHTS.json")]
        lights: Option<PathBuf>,
        /// Gather backend: auto, cpu, gpu or reference (default: $RADIOSITY_BACKEND, else auto).
        #[arg(long)]
        backend: Option<String>,
        /// Print JSON: {"patches", "bounces", "backend", "objects", "effects", "timings_ms"}.
        #[arg(long)]
        json: bool,
    },
    /// Render an image: ray-cast direct light with shadows plus the baked indirect light.
    Render {
        /// An OBJ scene (baked first, with the bake flags) or a .rad file.
        input: PathBuf,
        #[command(flatten)]
        bake: BakeArgs,
        /// Analytic lights (JSON: point, spot, directional) added to the scene's emitters.
        #[arg(long, value_name = "LIGHTS.json")]
        lights: Option<PathBuf>,
        /// Camera (JSON: position, look_at, up, fov_deg, width, height); default: framed automatically.
        #[arg(long, value_name = "CAMERA.json")]
        camera: Option<PathBuf>,
        /// Where to write the PNG (written atomically).
        #[arg(short, long)]
        output: PathBuf,
        /// Image width when the camera is framed automatically.
        #[arg(long, default_value_t = 512)]
        width: u32,
        /// Image height when the camera is framed automatically.
        #[arg(long, default_value_t = 512)]
        height: u32,
        /// Antialiasing: N×N camera samples per pixel (1 to 8).
        #[arg(long, default_value_t = 2)]
        aa: u32,
        /// Gather backend: auto, cpu, gpu or reference (default: $RADIOSITY_BACKEND, else auto).
        #[arg(long)]
        backend: Option<String>,
    },
    /// Object-to-object view factors of an OBJ scene, from its full-detail geometry.
    ViewFactors {
        /// The OBJ file.
        scene: PathBuf,
        /// Print JSON: {"objects", "areas", "matrix"}.
        #[arg(long)]
        json: bool,
    },
    /// Check sampled rows of the form-factor matrix against hemisphere rays (without the whole
    /// matrix): how far F's row sums are from the share of light that lands on patches.
    CheckRows(check_rows::CheckRowsArgs),
    /// Reference Monte-Carlo path tracing: per-object irradiance with standard errors, and an image.
    Pathtrace(pathtrace::PathtraceArgs),
    /// Time the gather in every format against its peers (faer, Jacobi, LU) on the embedded
    /// Cornell box, with errors and a roofline.
    Bench {
        /// Target patch count.
        #[arg(long, default_value_t = 4096)]
        patches: usize,
        /// Timed calls per method (default: about 0.8 s of calls each, 7 to 201).
        #[arg(long)]
        runs: Option<usize>,
        /// Print JSON: {"patches", "rows":[{"method", "ms", "kernel_ms", "bytes", "rel_error", …}], …}.
        #[arg(long)]
        json: bool,
    },
    /// Sweep patches, bounces, format, order and sparse threshold on the Cornell box: bake time,
    /// size, gather time and error (exact and path-traced) as REPORT.md, CSV and PNG plots.
    Report {
        /// A smaller sweep (about 2 minutes on 2 cores) instead of the full one (under 30).
        #[arg(long)]
        quick: bool,
        /// Output directory [default: report].
        #[arg(short, long)]
        output: Option<PathBuf>,
    },
    /// Print what a .rad file holds: sizes, format, order, effects, error estimates.
    Inspect {
        /// The .rad file.
        file: PathBuf,
        /// Print JSON instead of text.
        #[arg(long)]
        json: bool,
        /// Also write every matrix tile as a DDS texture into this directory.
        #[arg(long, value_name = "DIR")]
        export_dds: Option<PathBuf>,
    },
}

pub(crate) fn write_stdout(args: std::fmt::Arguments<'_>, newline: bool) {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    let result = out.write_fmt(args).and_then(|()| {
        if newline {
            out.write_all(b"\n")
        } else {
            Ok(())
        }
    });
    match result {
        Ok(()) => {}
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => std::process::exit(0),
        Err(e) => {
            eprintln!("error: cannot write to standard output: {e}");
            std::process::exit(1);
        }
    }
}

fn main() -> ExitCode {
    // Mesa's Vulkan device-select layer prints "error: XDG_RUNTIME_DIR is invalid…" to stderr
    // whenever adapters are listed on a machine without a desktop session, which breaks the
    // one-line error contract and alarms users for nothing; NODEVICE_SELECT=1 turns the layer
    // off (it only reorders GPUs). Measured: shared/notes/wgpu-on-cpu.md.
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: first statement of main, before any thread (rayon, wgpu) exists, so no other
        // thread can read or write the environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version: clap prints them as usual.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            // Usage errors keep the one-line contract: clap's first paragraph (which names the
            // flag, and its continuation lines such as the missing argument) on one line.
            let text = e.to_string();
            let first: Vec<&str> = text
                .lines()
                .take_while(|l| !l.trim().is_empty())
                .map(str::trim)
                .collect();
            let first = first.join(" ");
            eprintln!(
                "error: {} (see --help)",
                first.trim_start_matches("error: ")
            );
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::Bake {
            scene,
            output,
            bake,
            json,
        } => bake::run(&scene, &output, &bake, json),
        Command::Solve {
            input,
            bake,
            lights,
            backend,
            json,
        } => solve::run(&input, &bake, lights.as_deref(), backend.as_deref(), json),
        Command::Demo {
            out,
            backend,
            patches,
        } => demo::run(&out, backend.as_deref(), patches),
        Command::Render {
            input,
            bake,
            lights,
            camera,
            output,
            width,
            height,
            aa,
            backend,
        } => render::run(
            &input,
            &bake,
            lights.as_deref(),
            camera.as_deref(),
            &output,
            (width, height),
            aa,
            backend.as_deref(),
        ),
        Command::ViewFactors { scene, json } => view_factors::run(&scene, json),
        Command::Bench {
            patches,
            runs,
            json,
        } => bench::run(patches, json, runs),
        Command::Report { quick, output } => {
            report::output_dir(output).and_then(|dir| report::run(quick, &dir))
        }
        Command::Pathtrace(args) => pathtrace::run(&args),
        Command::CheckRows(args) => check_rows::run(&args),
        Command::Inspect {
            file,
            json,
            export_dds,
        } => inspect::run(&file, json, export_dds.as_deref()),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // One line: the context chain joined, never a backtrace. A cause its parent already
            // quotes (`{path}: {source}` errors) is not repeated.
            let mut msg: Vec<String> = Vec::new();
            for c in e.chain().map(|c| c.to_string()) {
                if !msg.last().is_some_and(|m| m.ends_with(&c)) {
                    msg.push(c);
                }
            }
            eprintln!("error: {}", msg.join(": ").replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}
