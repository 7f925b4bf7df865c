//! Camera files: `aerorect camera convert IN OUT` between aerorect's TOML and the formats of
//! OpenCV, COLMAP, OpenSfM/ODM, Metashape, DJI and Orthority (`aerorect::io::camera_formats`).

use crate::outputs::Files;
use aerorect::io::{CameraFormat, StagedOutputs, read_camera_file, text_from_camera};
use anyhow::{Context, Result, bail};
use clap::{Args, Subcommand};
use std::path::PathBuf;

#[derive(Args)]
pub struct CameraArgs {
    #[command(subcommand)]
    command: CameraCommand,
}

#[derive(Subcommand)]
enum CameraCommand {
    /// Converts a camera file between formats: toml, opencv-yaml, opencv-xml, colmap (cameras.txt),
    /// opensfm (cameras.json), metashape (calibration XML), dji-dewarp (DewarpData string),
    /// orthority (interior YAML). Formats from the extension and content unless given.
    Convert(ConvertArgs),
}

#[derive(Args)]
struct ConvertArgs {
    input: PathBuf,
    output: PathBuf,
    /// The input's format (else from its name and content).
    #[arg(long)]
    from: Option<String>,
    /// The output's format (else from its name).
    #[arg(long)]
    to: Option<String>,
    /// The image size WxH, for an input that does not state it (DewarpData), or to carry the
    /// camera to another size of the same aspect ratio.
    #[arg(long)]
    image_size: Option<String>,
}

pub fn camera_cmd(a: CameraArgs) -> Result<()> {
    match a.command {
        CameraCommand::Convert(c) => convert(c),
    }
}

fn format_named(flag: &str, name: &str) -> Result<CameraFormat> {
    CameraFormat::from_name(name).with_context(|| {
        let names: Vec<&str> = CameraFormat::ALL.iter().map(|f| f.name()).collect();
        format!("{flag} '{name}': expected one of {}", names.join(", "))
    })
}

fn convert(a: ConvertArgs) -> Result<()> {
    Files::new()
        .input("INPUT", Some(&a.input))
        .output("OUTPUT", Some(&a.output))
        .check()?;
    let from = a
        .from
        .as_deref()
        .map(|f| format_named("--from", f))
        .transpose()?;
    let to = match a.to.as_deref() {
        Some(t) => format_named("--to", t)?,
        None => match CameraFormat::detect(&a.output, None) {
            Some(f) => f,
            None => bail!(
                "{}: cannot tell the output format from the name: give --to",
                a.output.display()
            ),
        },
    };
    let size = a
        .image_size
        .as_deref()
        .map(crate::calib_cmds::parse_size)
        .transpose()?;
    let (camera, from) = read_camera_file(&a.input, from, size)?;
    let text = text_from_camera(&camera, to, &a.output.display().to_string())?;
    let mut staged = StagedOutputs::new();
    staged.text(&a.output, &text)?;
    staged.commit()?;
    let k = &camera.intrinsics;
    outln!(
        "{} ({}) -> {} ({}): {} x {}, fx {:.4}, fy {:.4}, cx {:.4}, cy {:.4}, lens {}",
        a.input.display(),
        from.name(),
        a.output.display(),
        to.name(),
        camera.size.width,
        camera.size.height,
        k.fx,
        k.fy,
        k.cx,
        k.cy,
        camera.distortion.as_ref().map_or("none", |d| d.kind())
    );
    Ok(())
}
