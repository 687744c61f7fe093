//! The `radiosity` command line (`docs/contract.md`, "Command line"). Thin: each subcommand parses its
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
mod check_rows;
mod demo;
mod embedded;
mod export_dds;
mod files;
mod inspect;
mod output;
mod pathtrace;
mod picture;
mod planned;
mod progress;
mod render;
mod report;
mod scene;
mod solve;
mod sunset;
mod view_factors;

use args::{BakeArgs, ProbeArgs};
use clap::{Parser, Subcommand};
use std::path::PathBuf;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "radiosity",
    version,
    about = "Precomputed-transfer radiosity: bake once, light every frame with one mat-vec",
    arg_required_else_help = true
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Bake the embedded Cornell box and light it: writes demo.png, demo.gif and demo.rad.
    Demo {
        #[command(flatten)]
        show: args::ShowArgs,
    },
    /// Bake the embedded town square once and set the sun over it: writes sunset.gif and
    /// sunset.rad (the sun and the sky change every frame, the file stays).
    Sunset {
        #[command(flatten)]
        show: args::ShowArgs,
        /// Frames of the animation, 1 to 600.
        #[arg(long, value_name = "N", default_value_t = 30)]
        frames: usize,
        /// Frame width in pixels, 16 to 2048.
        #[arg(long, default_value_t = 400, value_parser = clap::value_parser!(u32).range(16..=2048))]
        width: u32,
        /// Frame height in pixels, 16 to 2048.
        #[arg(long, default_value_t = 240, value_parser = clap::value_parser!(u32).range(16..=2048))]
        height: u32,
    },
    /// Bake a scene (OBJ, or glTF 2.0 .gltf/.glb) into a compressed transfer matrix (.rad).
    Bake {
        /// The scene file: OBJ (+ MTL), or glTF 2.0 (.gltf or .glb).
        scene: PathBuf,
        /// Where to write the .rad file (written atomically).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        bake: BakeArgs,
        #[command(flatten)]
        probes: ProbeArgs,
        /// Bake with this plan (`radiosity bake-plan`): its grid, systems and flags; bake flags
        /// given as well must agree with it.
        #[arg(long, value_name = "PLAN.json")]
        plan: Option<PathBuf>,
        /// With --plan: an earlier bake with the same plan (its OLD.rad.rows cache beside
        /// it), whose unchanged systems and rays are taken over; the file is the same as a
        /// full bake's.
        #[arg(long, value_name = "OLD.rad", requires = "plan")]
        reuse: Option<PathBuf>,
        /// Print the bake report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Plan a bake for shards (`bake-shard`, `bake-assemble`, `scripts/ray_bake.py`) and rebakes
    /// (`bake --plan --reuse`): the grid, the systems as regions of space, the flags.
    BakePlan {
        /// The scene file.
        scene: PathBuf,
        /// Where to write the plan (JSON).
        #[arg(short, long)]
        output: PathBuf,
        #[command(flatten)]
        bake: BakeArgs,
        #[command(flatten)]
        probes: ProbeArgs,
        /// Shards: groups of neighbouring systems (default: one a system).
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..))]
        shards: Option<u32>,
        /// Print a JSON summary.
        #[arg(long)]
        json: bool,
    },
    /// One shard of a planned bake: its patches' burial surveys and ray-cast hit counts, written
    /// to OUT-DIR/rows-K-HASH.bin (named by its inputs: a retried shard writes the same file).
    BakeShard {
        /// The scene file.
        scene: PathBuf,
        /// The plan.
        #[arg(long, value_name = "PLAN.json")]
        plan: PathBuf,
        /// The shard, from 0.
        #[arg(long, value_name = "K")]
        shard: usize,
        /// Where to write the rows.
        #[arg(long, value_name = "DIR")]
        out_dir: PathBuf,
        /// An earlier bake with the same plan whose rays are taken over where nothing changed.
        #[arg(long, value_name = "OLD.rad")]
        reuse: Option<PathBuf>,
        /// Print one JSON line.
        #[arg(long)]
        json: bool,
    },
    /// Assemble a planned bake from every shard's rows: the same file as `bake --plan`.
    BakeAssemble {
        /// The scene file.
        scene: PathBuf,
        /// The plan.
        #[arg(long, value_name = "PLAN.json")]
        plan: PathBuf,
        /// The folder of the shards' rows.
        #[arg(long, value_name = "DIR")]
        rows: PathBuf,
        /// Where to write the level (and its cache, OUT.rad.rows).
        #[arg(short, long)]
        output: PathBuf,
        /// An earlier bake with the same plan whose unchanged systems are taken over.
        #[arg(long, value_name = "OLD.rad")]
        reuse: Option<PathBuf>,
        /// Print the bake report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Whether two .rad files are the same except the stored report's timings (exit 0, "same";
    /// else exit 1 and where they differ).
    Compare {
        /// One file.
        a: PathBuf,
        /// The other.
        b: PathBuf,
    },
    /// Light a scene (its emitters, plus analytic lights) and report per-object irradiance and radiosity.
    Solve(solve::SolveArgs),
    /// Render an image: ray-cast direct light with shadows plus the baked indirect light.
    Render(render::RenderArgs),
    /// Object-to-object view factors of a scene (OBJ or glTF), from its full-detail geometry.
    ViewFactors {
        /// The scene file: OBJ (+ MTL), or glTF 2.0 (.gltf or .glb).
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
        #[arg(long, value_name = "N", default_value_t = 4096, allow_negative_numbers = true, value_parser = args::patch_count)]
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

/// Parses the command line, noting which bake flags `solve` and `render` were given (a `.rad`
/// input refuses them: see [`BakeArgs::given`]).
fn parse() -> Result<Cli, clap::Error> {
    use clap::{CommandFactory, FromArgMatches};
    let matches = Cli::command().try_get_matches()?;
    let mut cli = Cli::from_arg_matches(&matches)?;
    if let (
        Some((_, sub)),
        Command::Solve(solve::SolveArgs { bake, .. })
        | Command::Render(render::RenderArgs { bake, .. })
        | Command::Bake { bake, .. }
        | Command::BakePlan { bake, .. },
    ) = (matches.subcommand(), &mut cli.command)
    {
        bake.given = BakeArgs::given_in(sub);
    }
    if let (Some((_, sub)), Command::Bake { bake, .. } | Command::BakePlan { bake, .. }) =
        (matches.subcommand(), &mut cli.command)
    {
        bake.given.extend(ProbeArgs::given_in(sub));
    }
    Ok(cli)
}

fn main() -> ExitCode {
    // Mesa's Vulkan device-select layer prints "error: XDG_RUNTIME_DIR is invalid…" to stderr
    // whenever adapters are listed on a machine without a desktop login, which breaks the
    // one-line error contract and alarms users for nothing; NODEVICE_SELECT=1 turns the layer
    // off (it only reorders GPUs).
    if std::env::var_os("NODEVICE_SELECT").is_none() {
        // SAFETY: first statement of main, before any thread (rayon, wgpu) exists, so no other
        // thread can read or write the environment concurrently.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
    let cli = match parse() {
        Ok(cli) => cli,
        Err(e) => return usage(&e),
    };
    match run(cli.command) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {}", error_line(&e));
            ExitCode::FAILURE
        }
    }
}

/// What a command line clap refused or answered itself ends with: `radiosity` alone gets
/// the help on stderr with clap's usage-error status, `--help` and `--version` their text,
/// and a usage error one line.
fn usage(e: &clap::Error) -> ExitCode {
    if e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
        let _ = e.print();
        return ExitCode::from(2);
    }
    if !e.use_stderr() {
        let _ = e.print();
        return ExitCode::SUCCESS;
    }
    // Usage errors keep the one-line contract: clap's first paragraph (which names the flag,
    // and its continuation lines such as the missing argument) on one line.
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
    ExitCode::from(2)
}

/// Runs one subcommand: its exit status (`compare`'s 1 for files that differ), or its error.
fn run(command: Command) -> anyhow::Result<ExitCode> {
    let result = match command {
        Command::Bake {
            scene,
            output,
            bake,
            probes,
            plan: Some(plan),
            reuse,
            json,
        } => planned::run_bake(
            &scene,
            &output,
            &bake,
            &probes,
            &plan,
            reuse.as_deref(),
            json,
        ),
        Command::Bake {
            scene,
            output,
            bake,
            probes,
            json,
            ..
        } => bake::run(&scene, &output, &bake, &probes, json),
        Command::BakePlan {
            scene,
            output,
            bake,
            probes,
            shards,
            json,
        } => planned::run_plan(
            &scene,
            &output,
            &bake,
            &probes,
            shards.map(|k| k as usize),
            json,
        ),
        Command::BakeShard {
            scene,
            plan,
            shard,
            out_dir,
            reuse,
            json,
        } => planned::run_shard(&scene, &plan, shard, &out_dir, reuse.as_deref(), json),
        Command::BakeAssemble {
            scene,
            plan,
            rows,
            output,
            reuse,
            json,
        } => planned::run_assemble(&scene, &plan, &rows, &output, reuse.as_deref(), json),
        Command::Compare { a, b } => {
            let same = planned::run_compare(&a, &b)?;
            return Ok(if same {
                ExitCode::SUCCESS
            } else {
                ExitCode::from(1)
            });
        }
        Command::Solve(args) => solve::run(&args),
        Command::Demo { show } => demo::run(&show.out, show.backend.as_deref(), show.patches),
        Command::Sunset {
            show,
            frames,
            width,
            height,
        } => sunset::run(
            &show.out,
            show.backend.as_deref(),
            show.patches,
            frames,
            (width, height),
        ),
        Command::Render(args) => render::run(&args),
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
    result.map(|()| ExitCode::SUCCESS)
}

/// An error as one line: the context chain joined, never a backtrace. A cause its parent
/// already quotes (`{path}: {source}` errors) is not repeated.
pub(crate) fn error_line(e: &anyhow::Error) -> String {
    let mut msg: Vec<String> = Vec::new();
    for c in e.chain().map(|c| c.to_string()) {
        if !msg.last().is_some_and(|m| m.ends_with(&c)) {
            msg.push(c);
        }
    }
    msg.join(": ").replace('\n', " ")
}
