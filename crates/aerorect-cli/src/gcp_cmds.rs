//! `gcp-predict`: where each ground control point falls in each photo by the current
//! orientation, with a chip of the photo around it, so a user marks only where it is needed.

use crate::drone_cmds::FlightArgs;
use crate::outputs::Files;
use aerorect::core::RectifyLimits;
use aerorect::flight::{ControlOptions, FlightOptions, FlightPlan, chip};
use aerorect::io::{StagedOutputs, read_image};
use aerorect::raster::WarpOptions;
use anyhow::{Result, bail};
use clap::Args;
use std::collections::BTreeSet;
use std::path::PathBuf;

#[derive(Args)]
pub struct GcpPredictArgs {
    /// Ground control points (ODM gcp_list.txt, Pix4D or Metashape CSV, or ours; a Pix4D
    /// coordinates file and its marks file as two files).
    #[arg(required = true, num_args = 1..=2)]
    gcps: Vec<PathBuf>,
    /// The flight's photos.
    #[arg(long, required = true, num_args = 1..)]
    photos: Vec<PathBuf>,
    /// Where to write a chip of every photo around every point it sees (POINT_PHOTO.png, the
    /// predicted position at the chip's centre) and gcp_predicted.txt (ODM's gcp_list.txt of
    /// the predicted marks, to correct and use with --gcps).
    #[arg(long)]
    out_dir: Option<PathBuf>,
    /// Side of a chip, px.
    #[arg(long, default_value_t = 129)]
    chip_px: usize,
    #[command(flatten)]
    flight: FlightArgs,
}

pub fn gcp_predict(a: GcpPredictArgs) -> Result<()> {
    if !(8..=4096).contains(&a.chip_px) {
        bail!("--chip-px {}: a chip is 8 to 4096 px across", a.chip_px);
    }
    let listed = a.out_dir.as_ref().map(|d| d.join("gcp_predicted.txt"));
    let mut files = a.flight.inputs(Files::new()).inputs("GCPS", &a.gcps);
    files = files
        .inputs("--photos", &a.photos)
        .folder("--out-dir", a.out_dir.as_deref())
        .output("--out-dir (gcp_predicted.txt)", listed.as_deref());
    files.check()?;
    aerorect::io::refuse_duplicate_photos(&a.photos)?;
    let control = ControlOptions::read(&a.gcps)?;
    let opts = a
        .flight
        .options(&a.photos, RectifyLimits::default(), WarpOptions::default())?;
    let fo = FlightOptions {
        control: Some(control),
        ..FlightOptions::default()
    };
    let plan = FlightPlan::new(&a.photos, &opts, &fo)?;
    for w in plan.warnings() {
        eprintln!("warning: {w}");
    }
    let predictions = plan.predict_control()?;
    outln!("point,image,u,v,marked");
    for p in &predictions {
        outln!(
            "{},{},{:.2},{:.2},{}",
            p.point,
            p.image,
            p.pixel[0],
            p.pixel[1],
            p.marked
        );
    }
    let (Some(dir), Some(listed)) = (&a.out_dir, &listed) else {
        return Ok(());
    };
    std::fs::create_dir_all(dir)?;
    let mut staged = StagedOutputs::new();
    for (k, photo) in a.photos.iter().enumerate() {
        let here: Vec<_> = predictions.iter().filter(|p| p.frame == k).collect();
        if here.is_empty() {
            continue;
        }
        let image = read_image(photo)?;
        let stem = photo
            .file_stem()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned());
        for p in here {
            let name = format!("{}_{stem}.png", safe_name(&p.point));
            let side = a.chip_px as u32;
            let png = aerorect::io::thumbnail_png(&chip(&image, p.pixel, a.chip_px)?, side, &name)?;
            staged.bytes(&dir.join(name), &png)?;
        }
    }
    staged.text(listed, &plan.predictions_gcp_list(&predictions))?;
    staged.commit()?;
    outln!(
        "{} predicted marks of {} points; chips and {} written",
        predictions.len(),
        predictions
            .iter()
            .map(|p| &p.point)
            .collect::<BTreeSet<_>>()
            .len(),
        listed.display()
    );
    Ok(())
}

/// A point's name as a file name: anything but letters, digits, '-' and '_' becomes '_'.
fn safe_name(name: &str) -> String {
    name.chars()
        .map(
            |c| match c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                true => c,
                false => '_',
            },
        )
        .collect()
}
