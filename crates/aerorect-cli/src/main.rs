//! The `aerorect` command-line program: argument parsing and reports only; the work is in the
//! `aerorect` library.

#[macro_use]
mod stdout;

mod args;
mod baseline_cmds;
mod batch_cmds;
mod board_cmds;
mod calib_cmds;
mod camera_cmds;
mod commands;
mod drone_cmds;
mod flight_print;
mod gcp_cmds;
mod mosaic_cmds;
mod motion_cmds;
mod outputs;
mod plot;
mod signals;

use clap::{Parser, Subcommand};
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "aerorect",
    version,
    about = "Geometry of airborne camera images: rectify oblique frames from six attitude angles"
)]
struct Cli {
    /// Worker threads for pixel loops and the binarised JTC's two frame orders (default: all
    /// cores).
    #[arg(long, global = true, value_parser = at_least_one_thread)]
    threads: Option<usize>,
    /// The most pixels of one decoded input image (frames, references, DEMs): larger headers
    /// are refused before anything is allocated.
    #[arg(long, global = true, default_value_t = aerorect::io::DEFAULT_MAX_IMAGE_PIXELS)]
    max_image_px: u64,
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Rectify an oblique frame to the nadir standard image.
    Rectify(args::RectifyArgs),
    /// Render the oblique frame a camera would record of a flat scene (the inverse of rectify).
    Simulate(commands::SimulateArgs),
    /// Check-point accuracy of an attitude (eq. 19-20): du_max, dv_max, urms, vrms, rmse.
    Evaluate(commands::EvaluateArgs),
    /// The paper's attitude-error experiment: mean check-point error for random angle errors.
    Sensitivity(commands::SensitivityArgs),
    /// Simulate, rectify and evaluate a bundled real aerial photo; writes into out/demo/.
    Demo(commands::DemoArgs),
    /// Sub-pixel shift of CUR relative to REF (a feature at (x, y) in REF is at (x + dx, y + dy) in CUR).
    Shift(motion_cmds::ShiftArgs),
    /// The paper's shift experiment: error RMS by scene x SNR x method, with the CRLB, and a plot.
    MotionSim(motion_cmds::MotionSimArgs),
    /// Predicted image-motion velocities (eq. 1-5) and their error budgets.
    Velocity(motion_cmds::VelocityArgs),
    /// Streaming mode: each frame against the previous one; a CSV line per frame.
    Track(motion_cmds::TrackArgs),
    /// Calibrate intrinsics and lens distortion from control points (image,X,Y,Z,u,v).
    Calibrate(calib_cmds::CalibrateArgs),
    /// Remove lens distortion with the camera file's [distortion] table.
    Undistort(calib_cmds::UndistortArgs),
    /// Camera files: `camera convert IN OUT` between aerorect's TOML and OpenCV, COLMAP,
    /// OpenSfM/ODM, Metashape, DJI DewarpData and Orthority formats.
    Camera(camera_cmds::CameraArgs),
    /// The paper's comparison of Tsai, Brown and the improved model on a synthetic test field.
    DistortionCompare(calib_cmds::CompareArgs),
    /// Polynomial (or projective) correction from ground control points; residual per GCP.
    Gcp(baseline_cmds::GcpArgs),
    /// Register a frame to a reference image by automatic tie points; the output takes REFERENCE's grid.
    Register(baseline_cmds::RegisterArgs),
    /// The paper's Table 1: registration, quadratic, bilinear and six-angle corrections of a frame simulated from REFERENCE.
    Compare(baseline_cmds::CompareArgs),
    /// Rectify a whole flight from the photos' metadata into georeferenced frames.
    Batch(batch_cmds::BatchArgs),
    /// Misalignment of two georeferenced frames over their overlap (phase correlation of tiles).
    Overlap(drone_cmds::OverlapArgs),
    /// One mosaic of a flight's photos on one grid (optionally after --adjust), tile by tile.
    Mosaic(mosaic_cmds::MosaicArgs),
    /// Where each ground control point falls in each photo by the current orientation, with a
    /// chip of the photo around it (marking help for --gcps).
    GcpPredict(gcp_cmds::GcpPredictArgs),
}

/// `--threads`: a count of one or more (0 would silently mean "all cores" to the pool).
fn at_least_one_thread(text: &str) -> Result<usize, String> {
    match text.parse::<usize>() {
        Ok(0) => Err("at least one thread".into()),
        Ok(n) => Ok(n),
        Err(e) => Err(e.to_string()),
    }
}

/// `--threads n`, at most four times the cores (more only adds start-up time: 100 000 threads
/// took minutes to start), with a warning when cut.
fn capped_threads(n: usize) -> usize {
    let cores = std::thread::available_parallelism().map_or(1, |c| c.get());
    let most = 4 * cores;
    if n > most {
        eprintln!(
            "warning: --threads {n} is more than 4 x the {cores} cores available: using {most}"
        );
        most
    } else {
        n
    }
}

/// How the CLI spells the library's option keys: `--gsd-m 1e308`.
const FLAGS: aerorect::options::Spelling = aerorect::options::Spelling {
    prefix: "--",
    dashes: true,
    before_value: " ",
};

fn main() -> ExitCode {
    let cli = Cli::parse();
    FLAGS.use_for_process();
    signals::remove_partial_outputs_on_signal();
    aerorect::io::set_max_image_pixels(cli.max_image_px);
    if let Some(n) = cli.threads.map(capped_threads)
        && let Err(e) = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global()
    {
        eprintln!("error: --threads {n}: {e}");
        return ExitCode::FAILURE;
    }
    let result = match cli.command {
        Command::Rectify(a) => commands::rectify(a),
        Command::Simulate(a) => commands::simulate(a),
        Command::Evaluate(a) => commands::evaluate(a),
        Command::Sensitivity(a) => commands::sensitivity(a),
        Command::Gcp(a) => baseline_cmds::gcp(a),
        Command::Register(a) => baseline_cmds::register_cmd(a),
        Command::Compare(a) => baseline_cmds::compare(a),
        Command::Batch(a) => batch_cmds::batch(a),
        Command::Overlap(a) => drone_cmds::overlap(a),
        Command::Mosaic(a) => mosaic_cmds::mosaic_cmd(a),
        Command::GcpPredict(a) => gcp_cmds::gcp_predict(a),
        Command::Demo(a) => commands::demo(a),
        Command::Shift(a) => motion_cmds::shift(a),
        Command::MotionSim(a) => motion_cmds::motion_sim_cmd(a),
        Command::Velocity(a) => motion_cmds::velocity(a),
        Command::Track(a) => motion_cmds::track(a),
        Command::Calibrate(a) => calib_cmds::calibrate_cmd(a),
        Command::Undistort(a) => calib_cmds::undistort_cmd(a),
        Command::Camera(a) => camera_cmds::camera_cmd(a),
        Command::DistortionCompare(a) => calib_cmds::compare_cmd(a),
    };
    if let Err(e) = &result {
        eprintln!("error: {e:#}");
    }
    stdout::finish(result.is_ok())
}
