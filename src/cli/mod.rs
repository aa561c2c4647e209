//! Command-line parsing and dispatch. Errors are printed as one line; exit code 2.

mod args;
mod farm;
mod guard;
mod info;
mod info_mesh;
mod phase;
mod progress;
mod render;
mod report;
mod stitch;

use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Parser, Debug)]
#[command(
    name = "murk",
    version,
    about = "Render OpenVDB volume caches to multi-layer OpenEXR images"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Describe a .vdb file: its metadata and every grid (no trees are decoded without --stats);
    /// or a mesh (.vtu, .vtk): points, cells by type, bounds, point and cell data arrays.
    #[command(
        after_help = "Examples:\n  murk info fixtures/cloud.vdb\n  murk info fixtures/pyro.vdb --stats --json"
    )]
    Info {
        /// The .vdb, .vtu or .vtk file.
        file: PathBuf,
        /// Decode every float and vec3 grid and report value statistics and memory.
        #[arg(long)]
        stats: bool,
        /// Print JSON (stable keys, listed in docs/guide.md) instead of a table.
        #[arg(long)]
        json: bool,
    },
    /// Bake the deep shadow map of every light into a .vdb, for `murk render --shadow-cache`.
    #[command(after_help = render::BAKE_EXAMPLES)]
    BakeShadows {
        /// A .vdb file, or a scene .toml (flags override what it says).
        input: PathBuf,
        #[command(flatten)]
        options: Box<args::BakeArgs>,
        /// Bake this frame of a sequence: its number put into the frame patterns of INPUT
        /// and -o (as `murk stitch --frame`; for a farm's job).
        #[arg(long, value_name = "N")]
        frame: Option<i64>,
    },
    /// Run a fixed battery of stiff and extreme cases; print a pass/fail table and write
    /// stability.json.
    #[command(name = "check-stability", after_help = report::STABILITY_EXAMPLES)]
    CheckStability {
        /// Directory for stability.json (created if missing).
        #[arg(long, value_name = "DIR", default_value = ".")]
        out: PathBuf,
        /// Print the JSON instead of the table.
        #[arg(long)]
        json: bool,
    },
    /// Error against run time: sweep step, shadow-map tolerance and termination, time
    /// each render, compare with the reference; write converge.csv, .md and .png.
    #[command(after_help = report::CONVERGE_EXAMPLES)]
    Converge {
        /// A .vdb file, or a scene .toml.
        input: PathBuf,
        /// Directory for converge.csv, converge.md and converge.png (created if missing).
        #[arg(long, value_name = "DIR", default_value = ".")]
        out: PathBuf,
        /// Runs per setting; the median time is reported.
        #[arg(long, value_name = "N", default_value_t = 3)]
        runs: usize,
        #[command(flatten)]
        options: Box<args::RenderArgs>,
    },
    /// Write a render farm's job for a sequence: `murk farm openjd` (Open Job Description,
    /// for AWS Deadline Cloud).
    Farm {
        #[command(subcommand)]
        which: farm::FarmCommand,
    },
    /// Put the pieces of a frame rendered with `murk render --tile I/N` back together.
    #[command(
        after_help = "Examples:\n  murk stitch out.piece1of2.exr out.piece2of2.exr -o out.exr\n  murk stitch --frame 12 'out_####.p1.exr' 'out_####.p2.exr' -o 'out_####.exr' --preview 'out_####.png' --remove-pieces"
    )]
    Stitch(stitch::StitchArgs),
    /// Tabulate and plot a phase function (CSV, PNG), to see what a render will get.
    Phase {
        #[command(subcommand)]
        which: phase::PhaseCommand,
    },
    /// Render a .vdb or a mesh (.vtu, .vtk), or a scene .toml that names one, to a
    /// multi-layer EXR.
    #[command(after_help = render::EXAMPLES)]
    Render {
        /// A .vdb file, a mesh (.vtu, .vtk: its arrays are the grids), or a scene .toml (flags override what it says).
        input: PathBuf,
        #[command(flatten)]
        options: Box<args::RenderArgs>,
    },
}

/// Runs the command line; returns the process exit code.
pub fn run() -> i32 {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) if e.use_stderr() => {
            // clap's own text is several lines: keep its first, as one line, with the
            // indented lines that follow it (the missing arguments' names) joined on.
            let text = e.to_string();
            let mut lines = text.lines();
            let mut first = lines
                .next()
                .unwrap_or("invalid arguments")
                .trim_start_matches("error: ")
                .trim_end_matches(':')
                .to_string();
            let named: Vec<&str> = lines
                .take_while(|l| l.starts_with("  "))
                .map(str::trim)
                .collect();
            if !named.is_empty() {
                first = format!("{first}: {}", named.join(", "));
            }
            // clap's suggestion for a misspelt flag or value comes on a later line.
            if let Some(tip) = text.lines().find_map(|l| l.trim().strip_prefix("tip: ")) {
                first = match tip.split_once("similar ") {
                    Some((_, similar)) => match similar.split_once(" exists: ") {
                        Some((_, name)) => format!("{first}: did you mean {name}?"),
                        None => format!("{first} ({tip})"),
                    },
                    None => format!("{first} ({tip})"),
                };
            }
            eprintln!("murk: error: {first} (see murk --help)");
            return 2;
        }
        Err(e) => {
            let _ = e.print();
            return 0;
        }
    };
    let result = match cli.command {
        Command::Converge { options, .. }
            if options.sequence != args::SequenceArgs::default()
                || options.options.frames.is_some() =>
        {
            Err(anyhow::anyhow!(
                "murk converge times one image: --frames, --skip-existing and --tile are for murk render"
            ))
        }
        Command::Converge {
            input,
            out,
            runs,
            options,
        } => report::converge(&input, options.options(), &out, runs),
        Command::CheckStability { out, json } => match report::check_stability(&out, json) {
            Ok(true) => Ok(()),
            Ok(false) => return 1,
            Err(e) => Err(e),
        },
        Command::Info { file, json, .. } if murk::vtk::is_mesh_path(&file) => {
            info_mesh::run(&file, json)
        }
        Command::Info { file, stats, json } => info::run(&file, stats, json),
        Command::Phase { which } => phase::run(which),
        Command::Farm {
            which:
                farm::FarmCommand::Openjd {
                    input,
                    options,
                    tiles,
                    job,
                },
        } => farm::openjd(&input, *options, tiles, &job),
        Command::Stitch(a) => stitch::run(a),
        Command::Render { input, options } => {
            let sequence = options.sequence.clone();
            match render::run_sequence_or_frame(&input, options.options(), &sequence) {
                Ok(true) => Ok(()),
                Ok(false) => return 2,
                Err(e) => Err(e),
            }
        }
        Command::BakeShadows {
            input,
            options,
            frame,
        } => render::bake(&input, options.options(), frame),
    };
    match result {
        Ok(()) => 0,
        Err(e) => {
            eprintln!("murk: error: {}", one_line(&error_chain(&e)));
            2
        }
    }
}

/// The error and its causes, each cause added only if the text so far does not already
/// say it (library errors often include their source in their own message).
fn error_chain(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let c = cause.to_string();
        if text.is_empty() {
            text = c;
        } else if !text.contains(&c) {
            text = format!("{text}: {c}");
        }
    }
    text
}

fn one_line(s: &str) -> String {
    guard::message_text(&s.replace('\n', " "))
}

/// Writes to stdout; a closed pipe (`murk info ... | head`) is not an error.
fn print_stdout(text: &str) -> anyhow::Result<()> {
    use std::io::Write;
    let mut out = std::io::stdout().lock();
    match out.write_all(text.as_bytes()).and_then(|_| out.flush()) {
        Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => Err(e.into()),
        _ => Ok(()),
    }
}
