//! `batch --adjust`'s outputs, for every front end: each frame with its adjusted orientation,
//! the report, the adjusted poses and their CRS, and the accuracy report against ground
//! control, staged to land together (none when a frame fails).

use super::*;
use crate::drone::PhotoResult;
use aerorect_io::StagedOutputs;

/// What `batch --adjust` writes beside the frames: the report, the adjusted poses (as
/// `--poses` reads them), their CRS, and (with ground control) the accuracy report.
pub const ADJUSTMENT_FILES: [&str; 3] = [
    "adjustment.json",
    "adjusted_poses.csv",
    "adjusted_poses.prj",
];
pub const ACCURACY_FILE: &str = "accuracy.json";

/// The files of [`ADJUSTMENT_FILES`] (and [`ACCURACY_FILE`] with `control`) in `out_dir`.
pub fn adjustment_files(out_dir: &Path, control: bool) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = ADJUSTMENT_FILES.iter().map(|f| out_dir.join(f)).collect();
    if control {
        out.push(out_dir.join(ACCURACY_FILE));
    }
    out
}

impl AdjustedFlight {
    /// Stages every frame `k` to `outputs[k]` and the adjustment's files in `out_dir`, `jobs`
    /// frames at once (at most that many of their rasters in memory; each frame's warp also
    /// uses every thread); `each` sees every frame's result in frame order. A frame that fails
    /// fails the batch (naming every failed frame), and nothing of it is staged to land.
    pub fn stage_batch(
        &self,
        outputs: &[PathBuf],
        (out_dir, jobs): (&Path, usize),
        opts: &DroneOptions,
        staged: &mut StagedOutputs,
        mut each: impl FnMut(usize, &Result<PhotoResult, Error>),
    ) -> Result<Vec<PhotoResult>, Error> {
        if outputs.len() != self.len() {
            return Err(Error::Invalid(format!(
                "{} frames but {} outputs",
                self.len(),
                outputs.len()
            )));
        }
        let mut done = Vec::with_capacity(outputs.len());
        let mut failed = Vec::new();
        // `jobs` frames at a time in parallel, each staged apart; their results and staged
        // files are taken in frame order.
        let frames: Vec<usize> = (0..outputs.len()).collect();
        for chunk in frames.chunks(jobs.max(1)) {
            let written: Vec<_> = chunk
                .par_iter()
                .map(|&k| {
                    let mut own = StagedOutputs::new();
                    let r = self.write_frame_staged(k, &outputs[k], opts, &mut own);
                    (r, own)
                })
                .collect();
            for (&k, (r, own)) in chunk.iter().zip(written) {
                each(k, &r);
                match r {
                    Ok(p) => {
                        done.push(p);
                        staged.append(own);
                    }
                    Err(e) => failed.push(format!(
                        "{}: {}",
                        self.frames[k].input.display(),
                        e.full_message()
                    )),
                }
            }
        }
        if !failed.is_empty() {
            return Err(Error::Invalid(format!(
                "{} of {} frames failed ({}); nothing written: the adjusted frames and adjustment.json land together",
                failed.len(),
                outputs.len(),
                failed.join("; ")
            )));
        }
        let r = &self.report;
        let files = adjustment_files(out_dir, r.accuracy.is_some());
        staged.text(&files[0], &pretty(r)?)?;
        staged.text(&files[1], &r.poses_csv())?;
        staged.text(&files[2], &self.crs().to_wkt()?)?;
        if let Some(a) = &r.accuracy {
            staged.text(&files[3], &pretty(a)?)?;
        }
        Ok(done)
    }
}

/// A report as pretty JSON.
fn pretty<T: Serialize>(v: &T) -> Result<String, Error> {
    serde_json::to_string_pretty(v).map_err(Error::context("the report as JSON"))
}
