//! `mpm-cli`: run MPM scenes. Exit codes: 0 ok, 2 bad input, 3 numerical instability,
//! 130 / 143 / 129 a run stopped by SIGINT / SIGTERM / SIGHUP (after writing a checkpoint), 1
//! anything else.

use clap::{Parser, Subcommand};
use mpm_cli::render::RenderOptions;
use mpm_cli::run::RunOptions;
use mpm_cli::scene::overrides::Override;
use mpm_cli::scene::Precision;
use mpm_cli::surface::SurfaceOptions;
use mpm_cli::CliError;
use std::path::PathBuf;
use std::process::ExitCode;

/// The exit codes, shown by `--help`.
const EXIT_CODES: &str =
    "Exit codes: 0 ok, 1 other error (e.g. a file could not be written), 2 bad \
input, 3 numerical instability, 130 / 143 / 129 a run stopped by SIGINT (Ctrl-C) / SIGTERM / SIGHUP \
(a closed terminal): it finished \
its step and wrote a checkpoint, a snapshot and summary.json (status \"interrupted\"); continue \
it with --resume. A second signal ends it at once (killed by that signal); files written before \
stay complete.";

#[derive(Parser)]
#[command(
    name = "mpm-cli",
    version,
    about = "Material Point Method scenes: run, check, inspect, render, reconstruct surfaces",
    after_help = EXIT_CODES
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Also read .h5 files that have no checksum block (written or rewritten by another HDF5
    /// tool, or cut at the front). Unsafe: damage to their values goes unnoticed. Each such file
    /// is first read by a child process, so a crash or hang of the HDF5 library on a damaged
    /// file is reported as an error (exit code 2); MPM_UNCHECKED_TIMEOUT sets how many seconds
    /// that child may take (default 10, plus 1 per 20 MB).
    #[arg(long, global = true)]
    unchecked: bool,
}

#[derive(Subcommand)]
enum Command {
    /// Run a scene: HDF5 snapshots, run.xmf, checkpoints and summary.json in the output directory.
    ///
    /// SIGINT (Ctrl-C), SIGTERM or SIGHUP stops the run after the current step with a checkpoint
    /// ckpt_NNNNNN.h5, a snapshot and summary.json (status "interrupted"), exit code 130, 143 or
    /// 129; messages to a closed pipe or terminal are dropped without stopping the run;
    /// --resume continues it bitwise. A second signal ends the process at once, killed by that
    /// signal; every file written before stays complete (files are renamed into place when
    /// complete), and --resume from the newest checkpoint continues.
    #[command(after_help = EXIT_CODES)]
    Run {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Output directory (default: [output] directory of the scene).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Resume from this checkpoint (ckpt_NNNNNN.h5).
        #[arg(long)]
        resume: Option<PathBuf>,
        /// Number of worker threads (default: one per core).
        #[arg(long)]
        threads: Option<usize>,
        /// Store snapshot datasets in this precision, overriding [output] precision
        /// (checkpoints stay f64).
        #[arg(long, value_enum)]
        precision: Option<Precision>,
        /// gzip level 1-9 of snapshot datasets, or 0 for none, overriding [output] compression.
        #[arg(long, value_name = "LEVEL", value_parser = clap::value_parser!(u8).range(0..=9))]
        compression: Option<u8>,
        /// No progress output and no final report (warnings and errors still go to stderr;
        /// summary.json is written as always).
        #[arg(long)]
        quiet: bool,
        /// Override a scene key: KEY=VALUE with KEY a dotted path as `check` prints it
        /// (simulation.end_time, bodies[1].velocity, grid.min[0]) and VALUE a TOML value
        /// (0.5, [0.0, -9.81], "water"; other text is a string). Repeatable, applied in order;
        /// checked like the file, and stored in every snapshot's scene text.
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Check a scene: print it with defaults filled in, and the stage plan.
    Check {
        /// Scene file (TOML).
        scene: PathBuf,
        /// Override a scene key, as for `run` (repeatable).
        #[arg(long = "set", value_name = "KEY=VALUE")]
        set: Vec<String>,
    },
    /// Print the header and fields of a snapshot or checkpoint.
    Info {
        /// An .h5 file written by `mpm-cli run`, or a run's output directory.
        file: PathBuf,
        /// Also print the scene text stored in the file.
        #[arg(long)]
        scene: bool,
    },
    /// Render snapshots to PNG images in DIR/render/ (frame_NNNNNN.png; with --color-by or
    /// --view, frame_NNNNNN_FIELD_VIEW.png).
    Render {
        /// Output directory of a run.
        dir: PathBuf,
        /// Frame number to render (default: the last).
        #[arg(long, conflicts_with = "all")]
        frame: Option<u64>,
        /// Render every frame.
        #[arg(long)]
        all: bool,
        /// Field to colour by: material, phase, speed, or any field in the snapshot, e.g. phi_eff
        /// or concentration (default: material when several materials exist, else speed).
        #[arg(long)]
        color_by: Option<String>,
        /// Image width in pixels.
        #[arg(long, default_value_t = 800)]
        width: usize,
        /// Colour only the particles of this material (repeatable); the others are drawn in
        /// light grey beneath them.
        #[arg(long, value_name = "MATERIAL")]
        only: Vec<String>,
        /// Colour range of a continuous field, in its unit (default: its range over the
        /// rendered frames); values outside get the end colours.
        #[arg(long, num_args = 2, value_names = ["MIN", "MAX"], allow_negative_numbers = true)]
        range: Option<Vec<f64>>,
        /// 3D view: xy (x right, y up, from +z; the default), any other pair of axes (right,
        /// then up: yz, zx, yx, zy, xz), or iso (isometric from (1, 1, 1), y up). Pictures are
        /// named frame_NNNNNN[_FIELD][_VIEW][_range_MIN_MAX][_NAME].png after the --color-by,
        /// --view, --range and --name given.
        #[arg(long)]
        view: Option<String>,
        /// A name for this set of pictures, appended to their file names.
        #[arg(long)]
        name: Option<String>,
        /// Also assemble the rendered frames (with --all) into DIR/render/movie[...].mp4 or
        /// .gif with ffmpeg, when ffmpeg is installed (otherwise a message says so).
        #[arg(long, value_enum, num_args = 0..=1, default_missing_value = "mp4")]
        movie: Option<mpm_cli::render::MovieFormat>,
    },
    /// Reconstruct the fluid's surface of every 3D snapshot (or one, with --frame) as a
    /// triangle mesh with splashsurf, written to DIR/surface/surface_NNNNNN.ply (binary PLY,
    /// opened by Blender, ParaView, MeshLab) with per-vertex velocity vx vy vz and speed (m/s,
    /// averaged from the particles around each vertex) and material (an index; the file's
    /// comments name each). Prints each file with its vertex and triangle counts and enclosed
    /// volume. Of a 2D run, the outline of the fluid by marching squares at the same density
    /// level, drawn in DIR/surface/outline_NNNNNN.svg, with its segment count and enclosed
    /// area.
    ///
    /// Sizes are checked before anything is allocated: the radius, the kernel's reach and the
    /// cells no larger than the scene's domain, at most 2e9 marching-cubes cells and 2048
    /// neighbour candidates per particle, --iso below 2. An empty surface is an error, and a
    /// command that fails leaves no files behind.
    Surface {
        /// Output directory of a run.
        dir: PathBuf,
        /// Frame number to reconstruct (default: every frame).
        #[arg(long)]
        frame: Option<u64>,
        /// Material whose particles form the surface (repeatable; default: every fluid
        /// material of the scene).
        #[arg(long = "material", value_name = "MATERIAL")]
        materials: Vec<String>,
        /// Particle radius in m (default: half the median particle spacing, volume0^(1/3) / 2, or
        /// without volume0 in the snapshots half the spacing the stored scene samples with).
        #[arg(long, value_name = "M", allow_negative_numbers = true)]
        radius: Option<f64>,
        /// Kernel smoothing length in particle radii (the kernel reaches twice as far).
        #[arg(
            long,
            default_value_t = 2.0,
            value_name = "RADII",
            allow_negative_numbers = true
        )]
        smoothing_length: f64,
        /// Edge length of the marching-cubes cells in particle radii.
        #[arg(
            long,
            default_value_t = 0.5,
            value_name = "RADII",
            allow_negative_numbers = true
        )]
        cube_size: f64,
        /// Iso-surface level as a fraction of the rest density.
        #[arg(long, default_value_t = 0.6, allow_negative_numbers = true)]
        iso: f64,
    },
    /// Run a scene once per combination of values: `--set a=1,2,3 --set b=x,y` makes six runs
    /// (the first key varies slowest) into OUT/run_NNN, and OUT/sweep.csv with each run's values,
    /// exit code, status, steps, time, wall time, particles, mean dt and energy drift from its
    /// summary.json. Failed runs are recorded and the sweep goes on; it then exits with the
    /// first failure's code.
    Sweep {
        /// Scene file (TOML).
        scene: PathBuf,
        /// KEY=V1,V2,… (repeatable): the values KEY takes, TOML values separated by commas
        /// outside brackets and quotes.
        #[arg(long = "set", value_name = "KEY=V1,V2,…", required = true)]
        set: Vec<String>,
        /// Output directory of the sweep (default: the scene's [output] directory + "_sweep").
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Reads FILE once without verifying it and writes what it read to COPY with checksums,
    /// for a parent `mpm-cli --unchecked` (which survives this process crashing).
    #[command(hide = true, name = "probe")]
    Probe {
        /// The .h5 file.
        file: PathBuf,
        /// The checksummed copy to write.
        copy: PathBuf,
    },
}

/// The `--set` arguments parsed; a malformed one is bad input.
fn overrides(args: &[String]) -> Result<Vec<Override>, CliError> {
    args.iter()
        .map(|a| Override::parse(a).map_err(|e| CliError::BadInput(format!("error: {e}"))))
        .collect()
}

fn dispatch(cli: Cli) -> Result<(), CliError> {
    let trust = if cli.unchecked {
        mpm_io::Verify::Unchecked
    } else {
        mpm_io::Verify::Required
    };
    match cli.command {
        Command::Run {
            scene,
            out,
            resume,
            threads,
            precision,
            compression,
            quiet,
            set,
        } => mpm_cli::run::run(&RunOptions {
            scene,
            out,
            resume,
            threads,
            precision,
            compression,
            quiet,
            stop: Some(mpm_cli::run::stop_on_signals()?),
            trust,
            overrides: overrides(&set)?,
        }),
        Command::Check { scene, set } => {
            mpm_cli::out!("{}", mpm_cli::check::check(&scene, &overrides(&set)?)?);
            Ok(())
        }
        Command::Info { file, scene } => {
            mpm_cli::out!("{}", mpm_cli::info::info(&file, scene, trust)?);
            Ok(())
        }
        Command::Render {
            dir,
            frame,
            all,
            color_by,
            width,
            only,
            range,
            view,
            name,
            movie,
        } => {
            let r = mpm_cli::render::render(&RenderOptions {
                dir,
                frame,
                all,
                color_by,
                width,
                only,
                range: range.map(|r| (r[0], r[1])),
                view,
                name,
                movie,
                trust,
            })?;
            for f in r.files.iter().chain(&r.movie) {
                mpm_cli::outln!("{}", f.display());
            }
            for line in r.range.iter().chain(&r.notes) {
                mpm_cli::errln!("{line}");
            }
            Ok(())
        }
        Command::Surface {
            dir,
            frame,
            materials,
            radius,
            smoothing_length,
            cube_size,
            iso,
        } => {
            let files = mpm_cli::surface::surface(&SurfaceOptions {
                dir,
                frame,
                materials,
                radius,
                smoothing_length,
                cube_size,
                iso,
                trust,
            })?;
            for f in files {
                if f.dim == 2 {
                    mpm_cli::outln!(
                        "{}: {} particles, {} segments, area {:.6e} m^2",
                        f.path.display(),
                        f.particles,
                        f.segments,
                        f.volume
                    );
                } else {
                    mpm_cli::outln!(
                        "{}: {} particles, {} vertices, {} triangles, volume {:.6e} m^3",
                        f.path.display(),
                        f.particles,
                        f.vertices,
                        f.triangles,
                        f.volume
                    );
                }
            }
            Ok(())
        }
        Command::Sweep { scene, set, out } => {
            let csv = mpm_cli::sweep::sweep(&mpm_cli::sweep::SweepOptions {
                scene,
                sets: set,
                out,
                stop: Some(mpm_cli::run::stop_on_signals()?),
            })?;
            mpm_cli::outln!("{}", csv.display());
            Ok(())
        }
        Command::Probe { file, copy } => mpm_cli::files::probe(&file, &copy),
    }
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    // MPI lives until main returns (a no-op without the `mpi` feature).
    let _mpi = matches!(cli.command, Command::Run { .. }).then(mpm_cli::distributed::init);
    match dispatch(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // Rank 0 reports what every rank meets; another rank reports its own failures
            // (e.g. a piece it could not write).
            if !mpm_cli::distributed::root() && matches!(e, CliError::Other(_)) {
                use std::io::Write as _;
                let rank = mpm_cli::distributed::rank();
                let _ = writeln!(std::io::stderr(), "rank {rank}: {e}");
            }
            mpm_cli::errln!("{e}");
            let code = e.exit_code() as u8;
            mpm_cli::distributed::end_job(code);
            ExitCode::from(code)
        }
    }
}
