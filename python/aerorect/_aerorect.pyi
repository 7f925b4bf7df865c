"""Type stubs of the native module `aerorect._aerorect` (the Rust extension)."""

from os import PathLike
from typing import Any, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

_Path = Union[str, PathLike[str]]
# (bands, rows, cols) or (rows, cols); uint8, uint16 or float32.
_Array = npt.NDArray[Any]

__version__: str
DEFAULT_MAX_OUTPUT_PX: int

class AerorectError(ValueError):
    """Bad input, a bad value in a file, a geometry with no answer; the CLI's message."""

class AerorectFileError(OSError):
    """A file that could not be read or written; the CLI's message."""

class Camera:
    """A frame camera: intrinsics in pixels of `width` x `height`, optional lens model."""

    @staticmethod
    def from_file(path: _Path, image_size: Optional[Tuple[int, int]] = None) -> Camera: ...
    @staticmethod
    def from_metadata(path: _Path) -> Camera: ...
    @staticmethod
    def from_intrinsics(
        fx: float,
        fy: float,
        cx: float,
        cy: float,
        width: int,
        height: int,
        distortion: Optional[Mapping[str, Any]] = None,
    ) -> Camera: ...
    def resized(self, width: int, height: int) -> Camera: ...
    @property
    def fx(self) -> float: ...
    @property
    def fy(self) -> float: ...
    @property
    def cx(self) -> float: ...
    @property
    def cy(self) -> float: ...
    @property
    def width(self) -> int: ...
    @property
    def height(self) -> int: ...
    @property
    def distortion(self) -> Optional[Dict[str, Any]]: ...
    def to_toml(self) -> str: ...
    def __eq__(self, other: object) -> bool: ...

class AdjustedFlight:
    """A flight after the joint adjustment of its attitudes and cameras."""

    @property
    def report(self) -> Dict[str, Any]: ...
    def __len__(self) -> int: ...
    def write_frame(self, k: int, out: _Path) -> Dict[str, Any]: ...
    def mosaic(
        self, out: _Path, blend: str = "feather", feather_px: int = 16, cog: bool = False
    ) -> Dict[str, Any]: ...

def rectify_photo(
    path: _Path, opts: Optional[Mapping[str, Any]] = None
) -> Tuple[_Array, Dict[str, Any], Dict[str, Any]]: ...
def rectify_photo_to_file(
    path: _Path, out: _Path, opts: Optional[Mapping[str, Any]] = None
) -> Dict[str, Any]: ...
def read_photo_metadata(path: _Path) -> Dict[str, Any]: ...
def rectify(
    array: _Array,
    camera: Camera,
    attitude: Union[str, Mapping[str, float]],
    *,
    interp: str = "bilinear",
    nodata: float = 0.0,
    alpha: bool = False,
    altitude_m: Optional[float] = None,
    base_altitude_m: Optional[float] = None,
    max_output_px: int = ...,
) -> Tuple[_Array, Dict[str, Any]]: ...
def warp(
    array: _Array,
    homography: Sequence[Sequence[float]],
    shape: Tuple[int, int],
    *,
    interp: str = "bilinear",
    nodata: float = 0.0,
    alpha: bool = False,
) -> _Array: ...
def undistort(
    array: _Array,
    camera: Camera,
    *,
    fit: bool = False,
    interp: str = "bilinear",
    nodata: float = 0.0,
) -> Tuple[_Array, Camera]: ...
def shift(a: _Array, b: _Array, method: str = "jtc") -> Dict[str, float]: ...
def calibrate(
    points: Union[_Path, Sequence[Tuple[str, float, float, float, float, float]]],
    image_size: Tuple[int, int],
    model: str = "opencv",
    *,
    fix: Sequence[str] = ...,
    skew: bool = False,
    fix_aspect: bool = False,
    stop_px: float = 0.01,
    max_iterations: int = 200,
) -> Tuple[Camera, Dict[str, Any]]: ...
def batch(
    paths: Sequence[_Path],
    out_dir: _Path,
    opts: Optional[Mapping[str, Any]] = None,
    jobs: int = 2,
    force: bool = False,
    format: str = "tif",
    report_html: Optional[_Path] = None,
) -> Dict[str, Any]: ...
def adjust_flight(
    paths: Sequence[_Path], opts: Optional[Mapping[str, Any]] = None
) -> AdjustedFlight: ...
def write_adjusted_batch(
    paths: Sequence[_Path],
    out_paths: Sequence[_Path],
    out_dir: _Path,
    opts: Optional[Mapping[str, Any]] = None,
    jobs: int = 2,
) -> Dict[str, Any]: ...
def mosaic(
    paths: Sequence[_Path],
    out: _Path,
    opts: Optional[Mapping[str, Any]] = None,
    adjust: bool = False,
    blend: str = "feather",
    feather_px: int = 16,
) -> Dict[str, Any]: ...

class MosaicTiles:
    """A planned mosaic: its grid and its output tiles (row-major)."""

    @property
    def size(self) -> Tuple[int, int]: ...
    @property
    def windows(self) -> List[Tuple[int, int, int, int]]: ...
    def render(self, indices: Sequence[int]) -> Tuple[List[_Array], List[int]]: ...
    def write(self, out: _Path, fetch: Any, cells: Sequence[int]) -> Dict[str, Any]: ...

def plan_mosaic(
    paths: Sequence[_Path],
    opts: Optional[Mapping[str, Any]] = None,
    blend: str = "feather",
    feather_px: int = 16,
) -> MosaicTiles: ...
