//! Lens distortion in practice: calibration input from files (control points, chessboard
//! photos: [`calibration`]) and undistortion ([`undistort`]).

pub mod calibration;
pub mod undistort;
