//! The adjustment's named parameter blocks: a frame's rotation and position corrections, a
//! camera's focal scale, principal point shift, radial terms and boresight, the datum of the
//! GPS positions against ground control, and where each free one sits in the reduced system
//! (frames, cameras and datum; the tie points are eliminated).
//! A parameter that is held (not refined, or held for a gauge freedom) has no index: it
//! stays at zero. Nothing outside this file does offset arithmetic into a parameter vector.

use aerorect_core::Vec3;

/// A frame parameter: the rotation correction (world axes, radians) or the position
/// correction (world axes, metres), by axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum FrameParam {
    Rotation(usize),
    Position(usize),
}

/// A frame's parameters in the order of a frame's Jacobian columns.
pub(super) const FRAME_PARAMS: [FrameParam; 6] = [
    FrameParam::Rotation(0),
    FrameParam::Rotation(1),
    FrameParam::Rotation(2),
    FrameParam::Position(0),
    FrameParam::Position(1),
    FrameParam::Position(2),
];

/// A camera parameter: focal scale s (fx, fy times 1 + s), principal point shift (px), the
/// radial terms dk1, dk2 and the boresight rotation (camera axes, radians).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum CameraParam {
    FocalScale,
    PrincipalPoint(usize),
    Radial(usize),
    Boresight(usize),
}

/// A camera's parameters in the order of a camera's Jacobian columns.
pub(super) const CAMERA_PARAMS: [CameraParam; 8] = [
    CameraParam::FocalScale,
    CameraParam::PrincipalPoint(0),
    CameraParam::PrincipalPoint(1),
    CameraParam::Radial(0),
    CameraParam::Radial(1),
    CameraParam::Boresight(0),
    CameraParam::Boresight(1),
    CameraParam::Boresight(2),
];

/// A datum parameter: what the GPS positions' frame is off from the ground control's (or the
/// images') by, as a shift (m), a small rotation (rotation vector, radians) and a scale about
/// the frames' centroid (see [`super::Datum`]), and a drift (m over the flight, linear in each
/// frame's time: see [`super::AdjustOptions::gps_drift_times`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum DatumParam {
    Shift(usize),
    Rotation(usize),
    Scale,
    Drift(usize),
}

/// The datum's parameters in order.
pub(super) const DATUM_PARAMS: [DatumParam; 10] = [
    DatumParam::Shift(0),
    DatumParam::Shift(1),
    DatumParam::Shift(2),
    DatumParam::Rotation(0),
    DatumParam::Rotation(1),
    DatumParam::Rotation(2),
    DatumParam::Scale,
    DatumParam::Drift(0),
    DatumParam::Drift(1),
    DatumParam::Drift(2),
];

/// The datum's values.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct DatumBlock {
    pub shift: Vec3,
    pub rotation: Vec3,
    pub scale: f64,
    pub drift: Vec3,
}

impl DatumBlock {
    pub fn get(&self, p: DatumParam) -> f64 {
        match p {
            DatumParam::Shift(k) => self.shift[k],
            DatumParam::Rotation(k) => self.rotation[k],
            DatumParam::Scale => self.scale,
            DatumParam::Drift(k) => self.drift[k],
        }
    }
    pub fn get_mut(&mut self, p: DatumParam) -> &mut f64 {
        match p {
            DatumParam::Shift(k) => &mut self.shift[k],
            DatumParam::Rotation(k) => &mut self.rotation[k],
            DatumParam::Scale => &mut self.scale,
            DatumParam::Drift(k) => &mut self.drift[k],
        }
    }
}

/// One frame's corrections.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct FrameBlock {
    pub rotation: Vec3,
    pub position: Vec3,
}

impl FrameBlock {
    pub fn get(&self, p: FrameParam) -> f64 {
        match p {
            FrameParam::Rotation(k) => self.rotation[k],
            FrameParam::Position(k) => self.position[k],
        }
    }
    pub fn get_mut(&mut self, p: FrameParam) -> &mut f64 {
        match p {
            FrameParam::Rotation(k) => &mut self.rotation[k],
            FrameParam::Position(k) => &mut self.position[k],
        }
    }
}

/// One camera's corrections.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(super) struct CameraBlock {
    pub focal_scale: f64,
    pub principal_point: [f64; 2],
    pub radial: [f64; 2],
    pub boresight: Vec3,
}

impl CameraBlock {
    pub fn get(&self, p: CameraParam) -> f64 {
        match p {
            CameraParam::FocalScale => self.focal_scale,
            CameraParam::PrincipalPoint(k) => self.principal_point[k],
            CameraParam::Radial(k) => self.radial[k],
            CameraParam::Boresight(k) => self.boresight[k],
        }
    }
    pub fn get_mut(&mut self, p: CameraParam) -> &mut f64 {
        match p {
            CameraParam::FocalScale => &mut self.focal_scale,
            CameraParam::PrincipalPoint(k) => &mut self.principal_point[k],
            CameraParam::Radial(k) => &mut self.radial[k],
            CameraParam::Boresight(k) => &mut self.boresight[k],
        }
    }
}

/// The solver's state: every block's value and every tie point's ground position.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct State {
    pub frames: Vec<FrameBlock>,
    pub cameras: Vec<CameraBlock>,
    pub datum: DatumBlock,
    pub points: Vec<Vec3>,
}

/// The columns of one observation's Jacobian: a frame's six, then its camera's eight.
pub(super) const LOCAL: usize = 14;

/// Where each free parameter sits in the reduced system.
#[derive(Debug, Clone)]
pub(super) struct Layout {
    frames: Vec<[Option<usize>; 6]>,
    cameras: Vec<[Option<usize>; 8]>,
    datum: [Option<usize>; DATUM_PARAMS.len()],
    len: usize,
}

impl Layout {
    /// `frame_free(f, p)`, `camera_free(c, p)` and `datum_free(p)` say which parameters are
    /// solved for.
    pub fn new(
        frames: usize,
        cameras: usize,
        frame_free: impl Fn(usize, FrameParam) -> bool,
        camera_free: impl Fn(usize, CameraParam) -> bool,
        datum_free: impl Fn(DatumParam) -> bool,
    ) -> Self {
        let mut len = 0;
        let mut next = |free: bool| {
            free.then(|| {
                len += 1;
                len - 1
            })
        };
        let frames = (0..frames)
            .map(|f| FRAME_PARAMS.map(|p| next(frame_free(f, p))))
            .collect();
        let cameras = (0..cameras)
            .map(|c| CAMERA_PARAMS.map(|p| next(camera_free(c, p))))
            .collect();
        let datum = DATUM_PARAMS.map(|p| next(datum_free(p)));
        Self {
            frames,
            cameras,
            datum,
            len,
        }
    }

    /// The number of free parameters (the reduced system's size).
    pub fn len(&self) -> usize {
        self.len
    }

    #[cfg(test)]
    pub fn camera(&self, c: usize, p: CameraParam) -> Option<usize> {
        CAMERA_PARAMS
            .iter()
            .position(|q| *q == p)
            .and_then(|k| self.cameras[c][k])
    }

    /// The reduced-system index of a frame parameter (none when it is held).
    #[cfg(test)]
    pub fn frame_index(&self, f: usize, p: FrameParam) -> Option<usize> {
        FRAME_PARAMS
            .iter()
            .position(|q| *q == p)
            .and_then(|k| self.frames[f][k])
    }

    /// The reduced-system index of a datum parameter (none when it is held).
    pub fn datum(&self, p: DatumParam) -> Option<usize> {
        DATUM_PARAMS
            .iter()
            .position(|q| *q == p)
            .and_then(|k| self.datum[k])
    }

    /// The reduced-system index of each column of an observation's Jacobian in frame `f` of
    /// camera `c` (a frame's six, then the camera's eight).
    pub fn local(&self, f: usize, c: usize) -> [Option<usize>; LOCAL] {
        let mut out = [None; LOCAL];
        out[..6].copy_from_slice(&self.frames[f]);
        out[6..].copy_from_slice(&self.cameras[c]);
        out
    }

    /// The parameter blocks of the reduced system: each frame's free parameters, each
    /// camera's, the datum's (each block's indices are consecutive).
    pub fn blocks(&self) -> super::normal::Blocks {
        let count = |ix: &[Option<usize>]| ix.iter().filter(|i| i.is_some()).count();
        let frames = self.frames.iter().map(|ix| count(ix));
        let cameras = self.cameras.iter().map(|ix| count(ix));
        super::normal::Blocks::new(frames.chain(cameras).chain([count(&self.datum)]))
    }

    /// Every free parameter with its index: frame ones, then camera ones.
    pub fn free(&self) -> impl Iterator<Item = (usize, Param)> + '_ {
        let frames = self.frames.iter().enumerate().flat_map(|(f, ix)| {
            ix.iter()
                .zip(FRAME_PARAMS)
                .filter_map(move |(i, p)| Some((((*i)?), Param::Frame(f, p))))
        });
        let cameras = self.cameras.iter().enumerate().flat_map(|(c, ix)| {
            ix.iter()
                .zip(CAMERA_PARAMS)
                .filter_map(move |(i, p)| Some((((*i)?), Param::Camera(c, p))))
        });
        let datum = self
            .datum
            .iter()
            .zip(DATUM_PARAMS)
            .filter_map(|(i, p)| Some(((*i)?, Param::Datum(p))));
        frames.chain(cameras).chain(datum)
    }

    /// The free parameters' values in `s`, in index order.
    pub fn values(&self, s: &State) -> Vec<f64> {
        let mut v = vec![0.0; self.len];
        for (i, p) in self.free() {
            v[i] = p.value(s);
        }
        v
    }

    /// `s` moved by `dx` (one entry per free parameter).
    pub fn moved(&self, s: &State, dx: &[f64]) -> State {
        let mut out = s.clone();
        for (i, p) in self.free() {
            *p.value_mut(&mut out) += dx[i];
        }
        out
    }
}

/// A parameter by name: frame or camera (with its index), or the datum's.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub(super) enum Param {
    Frame(usize, FrameParam),
    Camera(usize, CameraParam),
    Datum(DatumParam),
}

impl Param {
    pub fn value(self, s: &State) -> f64 {
        match self {
            Param::Frame(f, p) => s.frames[f].get(p),
            Param::Camera(c, p) => s.cameras[c].get(p),
            Param::Datum(p) => s.datum.get(p),
        }
    }
    pub fn value_mut(self, s: &mut State) -> &mut f64 {
        match self {
            Param::Frame(f, p) => s.frames[f].get_mut(p),
            Param::Camera(c, p) => s.cameras[c].get_mut(p),
            Param::Datum(p) => s.datum.get_mut(p),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn held_parameters_have_no_index_and_the_rest_are_numbered_once() {
        let l = Layout::new(
            2,
            1,
            |f, p| f == 1 || matches!(p, FrameParam::Rotation(_)),
            |_, p| p == CameraParam::FocalScale,
            |p| p == DatumParam::Scale,
        );
        assert_eq!(l.len(), 3 + 6 + 1 + 1);
        assert_eq!(l.frame_index(0, FrameParam::Position(0)), None);
        assert_eq!(l.frame_index(1, FrameParam::Position(2)), Some(8));
        assert_eq!(l.datum(DatumParam::Scale), Some(10));
        assert_eq!(l.datum(DatumParam::Shift(0)), None);
        assert_eq!(l.camera(0, CameraParam::FocalScale), Some(9));
        let mut seen: Vec<usize> = l.free().map(|(i, _)| i).collect();
        seen.sort_unstable();
        assert_eq!(seen, (0..l.len()).collect::<Vec<_>>());
        let s = State {
            frames: vec![FrameBlock::default(); 2],
            cameras: vec![CameraBlock::default()],
            datum: DatumBlock::default(),
            points: vec![],
        };
        let dx: Vec<f64> = (0..l.len()).map(|i| i as f64 + 1.0).collect();
        let m = l.moved(&s, &dx);
        assert_eq!(m.frames[1].position[2], 9.0);
        assert_eq!(m.frames[0].position, Vec3::zeros());
        assert_eq!(m.cameras[0].focal_scale, 10.0);
        assert_eq!(m.datum.scale, 11.0);
        assert_eq!(l.values(&m), dx);
    }
}
