//! senseFly's roll sign, decided by the flight's own ties. Peer tools disagree on it (ODM
//! negates the recorded roll, OpenSfM and Orthority do not) and nothing records how the camera
//! sits in the airframe. With the reading left open ([`SenseflyRoll::Auto`]), the first round
//! is adjusted from the same feature ties (which need no attitude) under each reading, and the
//! reading under which the images turn the frames less from their recorded attitudes is kept:
//! the recorded angles are then closest to what the images say. The report's `sensefly_roll`
//! gives both rounds' numbers.

use super::*;
use crate::drone_options::SenseflyRoll;
use crate::photo_source::AttitudeSource;

/// How much less the flipped reading's first round must turn the frames (median) for the
/// flight to be read flipped: 10 %; on a tie the recorded reading (Pix4D's) stands.
pub const FLIP_MARGIN: f64 = 0.9;

/// The first round under one reading of the roll.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RollTrial {
    /// The median and largest attitude change from the recorded attitudes (degrees).
    pub median_turn_deg: f64,
    pub largest_turn_deg: f64,
    pub rms_after_px: f64,
}

/// How senseFly's roll was read, and the first round under each reading (`None`: that
/// round's adjustment failed).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RollChoice {
    pub reading: SenseflyRoll,
    pub as_recorded: Option<RollTrial>,
    pub flipped: Option<RollTrial>,
}

impl FlightPlan {
    /// Whether the flight leaves senseFly's roll to its images: the reading is
    /// [`SenseflyRoll::Auto`] and some frame's attitude is senseFly's body angles.
    fn roll_open(&self) -> bool {
        self.opts.sensefly_roll == SenseflyRoll::Auto
            && self.frames.iter().any(
                |f| matches!(f.info.attitude.source, AttitudeSource::Body(s) if s.is_sensefly()),
            )
    }

    /// This plan, or the same flight planned with senseFly's roll flipped, whichever reading
    /// the first round's ties (`features`) agree with (see the module). Unchanged when the
    /// reading is not open or there are no feature ties.
    pub fn with_sensefly_roll_chosen(self, features: &[PairMatch]) -> Result<Self, Error> {
        let Some((choice, flipped_plan)) = self.roll_trials(features)? else {
            return Ok(self);
        };
        let mut chosen = match choice.reading {
            SenseflyRoll::Flipped => flipped_plan,
            _ => self,
        };
        chosen.roll = Some(choice);
        Ok(chosen)
    }

    /// The reading of senseFly's roll the first round's ties (`features`) agree with, and both
    /// rounds' numbers; `None` when the reading is not open or there are no feature ties.
    pub fn choose_sensefly_roll(
        &self,
        features: &[PairMatch],
    ) -> Result<Option<RollChoice>, Error> {
        Ok(self.roll_trials(features)?.map(|(choice, _)| choice))
    }

    /// The choice and the flight planned with the roll flipped (on which it was tried).
    fn roll_trials(&self, features: &[PairMatch]) -> Result<Option<(RollChoice, Self)>, Error> {
        if features.is_empty() || !self.roll_open() {
            return Ok(None);
        }
        let flipped_plan = self.read_as(SenseflyRoll::Flipped)?;
        let as_recorded = self.first_round_trial(features);
        let flipped = flipped_plan.first_round_trial(features);
        let flip = match (&as_recorded, &flipped) {
            (Some(a), Some(f)) => f.median_turn_deg < FLIP_MARGIN * a.median_turn_deg,
            (None, Some(_)) => true,
            _ => false,
        };
        let reading = match flip {
            true => SenseflyRoll::Flipped,
            false => SenseflyRoll::AsRecorded,
        };
        let choice = RollChoice {
            reading,
            as_recorded,
            flipped,
        };
        Ok(Some((choice, flipped_plan)))
    }

    /// This plan with the reading `choice` made (by [`Self::with_sensefly_roll_chosen`] in
    /// another process: Dask's workers rebuild the plan), recorded for the report.
    pub fn with_sensefly_roll(self, choice: RollChoice) -> Result<Self, Error> {
        let mut plan = match choice.reading {
            SenseflyRoll::Flipped => self.read_as(SenseflyRoll::Flipped)?,
            _ => self,
        };
        plan.roll = Some(choice);
        Ok(plan)
    }

    /// How senseFly's roll was read, when the images decided it.
    pub fn sensefly_roll(&self) -> Option<&RollChoice> {
        self.roll.as_ref()
    }

    /// The same flight planned with senseFly's roll read as `roll`.
    fn read_as(&self, roll: SenseflyRoll) -> Result<Self, Error> {
        let inputs: Vec<PathBuf> = self.frames.iter().map(|f| f.input.clone()).collect();
        let opts = DroneOptions {
            sensefly_roll: roll,
            ..self.opts.clone()
        };
        let mut plan = FlightPlan::new(&inputs, &opts, &self.fo)?;
        plan.started = self.started;
        // The same photos.
        plan.decoded = std::sync::Arc::clone(&self.decoded);
        Ok(plan)
    }

    /// The first round adjusted from `features` alone (`None` if its adjustment fails); its
    /// capped solve only, also when it is the last round.
    fn first_round_trial(&self, features: &[PairMatch]) -> Option<RollTrial> {
        let mut progress = FlightProgress::default();
        self.adjust_round(&mut progress, features.to_vec(), false)
            .ok()?;
        let r = progress.rounds.last()?;
        Some(RollTrial {
            median_turn_deg: r.median_turn_deg,
            largest_turn_deg: r.largest_turn_deg,
            rms_after_px: r.rms_after_px,
        })
    }
}
