"""aerorect: the geometry of airborne camera images, from Python.

Drone photos orthorectified from their own metadata (``rectify_photo``), the building blocks
(``Camera``, ``rectify``, ``warp``, ``undistort``, ``shift``, ``calibrate``), the flight
adjustment and mosaic (``adjust_flight``, ``mosaic``), and whole flights on a Dask cluster
(``aerorect.distributed.rectify_flight``).

Arrays are NumPy ``(bands, rows, cols)`` like rasterio (a 2-D array is one band) of uint8,
uint16 or float32. The GIL is released around all heavy work, so threads run in parallel.
Errors raise :class:`AerorectError` (a ``ValueError``: bad input) or, when a file cannot be read
or written, :class:`AerorectFileError` (an ``OSError``), with the messages of the ``aerorect``
command-line program.
"""

from __future__ import annotations

import os
from typing import Any, Optional, Sequence, Tuple, Union

import numpy as np

from . import _aerorect
from ._aerorect import (
    DEFAULT_MAX_OUTPUT_PX,
    AdjustedFlight,
    AerorectError,
    AerorectFileError,
    Camera,
    calibrate,
    read_photo_metadata,
    rectify,
    shift,
    undistort,
    warp,
)

__version__ = _aerorect.__version__

PathLike = Union[str, "os.PathLike[str]"]

__all__ = [
    "AdjustedFlight",
    "AerorectError",
    "AerorectFileError",
    "Camera",
    "DEFAULT_MAX_OUTPUT_PX",
    "adjust_flight",
    "batch",
    "distributed",
    "calibrate",
    "mosaic",
    "read_photo_metadata",
    "rectify",
    "rectify_photo",
    "rectify_photo_to_file",
    "shift",
    "undistort",
    "warp",
]


def _opts(**kw: Any) -> dict:
    """The options the native functions take: paths as strings, None left out."""
    out = {}
    for k, v in kw.items():
        if v is None:
            continue
        if isinstance(v, os.PathLike):
            v = os.fspath(v)
        if isinstance(v, tuple):
            v = list(v)
        if isinstance(v, list):
            v = [os.fspath(x) if isinstance(x, os.PathLike) else x for x in v]
        out[k] = v
    return out


def rectify_photo(
    path: PathLike,
    gsd_m: Optional[float] = None,
    dem: Optional[PathLike] = None,
    *,
    ground_height_m: Optional[float] = None,
    vertical_offset_m: float = 0.0,
    strict: bool = False,
    occlusion: bool = False,
    crs: Optional[str] = None,
    camera: Optional[PathLike] = None,
    boresight_deg: Optional[Sequence[float]] = None,
    lever_arm_m: Optional[Sequence[float]] = None,
    pose: Optional[Sequence[float]] = None,
    interp: str = "bilinear",
    nodata: float = 0.0,
    alpha: bool = False,
    max_output_px: int = DEFAULT_MAX_OUTPUT_PX,
    with_report: bool = False,
) -> Tuple[np.ndarray, dict]:
    """Orthorectify a drone photo from its own metadata, in memory.

    The same as ``aerorect rectify PATH OUT [--gsd-m G] [--dem DEM] ...`` (without
    ``--attitude``): the same pixels, the same georeferencing, nothing written.

    Returns ``(array, profile)``: ``array`` shaped ``(bands, rows, cols)`` (the photo's sample
    type; an alpha band last with ``alpha=True``), ``profile`` a rasterio profile (``driver``,
    ``crs`` as EPSG:code, WKT or PROJ text, ``transform`` as Affine's ``(a, b, c, d, e, f)``,
    ``nodata``, ``width``, ``height``, ``count``, ``dtype``), so that
    ``rasterio.open(p, "w", **{**profile, "transform": Affine(*profile["transform"])})``
    writes it. With ``with_report=True``: ``(array, profile, report)``, the report being
    ``aerorect rectify --report``'s (camera, pose, GSD, warnings...).

    ``pose`` = (x, y, z, omega, phi, kappa) in ``crs`` replaces the metadata's orientation
    (``--pose``); ``boresight_deg`` and ``lever_arm_m`` are three numbers each.
    """
    o = _opts(
        gsd_m=gsd_m,
        dem=dem,
        ground_height_m=ground_height_m,
        vertical_offset_m=vertical_offset_m,
        strict=strict,
        occlusion=occlusion,
        crs=crs,
        camera=camera,
        boresight_deg=boresight_deg,
        lever_arm_m=lever_arm_m,
        pose=pose,
        interp=interp,
        nodata=nodata,
        alpha=alpha,
        max_output_px=max_output_px,
    )
    array, profile, report = _aerorect.rectify_photo(os.fspath(path), o)
    if with_report:
        return array, profile, report
    return array, profile


def rectify_photo_to_file(
    path: PathLike, out: PathLike, *, cog: bool = False, **kwargs: Any
) -> dict:
    """``aerorect rectify PATH OUT`` (GeoTIFF, ``cog=True`` a cloud-optimised GeoTIFF, or
    ``.png`` with a world file), written atomically. Keyword arguments as
    :func:`rectify_photo`. Returns the report."""
    return _aerorect.rectify_photo_to_file(
        os.fspath(path), os.fspath(out), _opts(cog=cog, **kwargs)
    )


def batch(
    paths: Sequence[PathLike],
    out_dir: PathLike,
    gsd_m: Optional[float] = None,
    dem: Optional[PathLike] = None,
    *,
    jobs: int = 2,
    force: bool = False,
    format: str = "tif",
    report_html: Optional[PathLike] = None,
    **kwargs: Any,
) -> dict:
    """``aerorect batch PATHS --out-dir OUT_DIR``: every photo to ``OUT_DIR/STEM.tif`` (or
    ``.png`` with a world file), ``jobs`` at once; an existing whole output is skipped unless
    ``force``. Keyword arguments as :func:`rectify_photo`, and ``geo`` (an external-orientation
    file), ``poses``, ``cog``. Returns ``{"frames": [{"input", "status", "why", "report"}],
    "seconds"}``; raises, naming every failed photo, when one fails (the others are written).
    With ``adjust`` use :func:`adjust_flight` and its ``write_frame``."""
    o = _opts(gsd_m=gsd_m, dem=dem, **kwargs)
    return _aerorect.batch(
        [os.fspath(p) for p in paths],
        os.fspath(out_dir),
        o,
        jobs,
        force,
        format,
        None if report_html is None else os.fspath(report_html),
    )


def adjust_flight(
    paths: Sequence[PathLike],
    gsd_m: Optional[float] = None,
    dem: Optional[PathLike] = None,
    *,
    adjust_positions_m: Optional[float] = None,
    **kwargs: Any,
) -> AdjustedFlight:
    """Match a flight's overlaps and adjust attitudes and cameras jointly (``batch
    --adjust``). The result writes each frame with its adjusted orientation
    (``write_frame(k, out)``), mosaics them (``mosaic(out)``) and holds the ``report``.
    Keyword arguments as :func:`rectify_photo`, and ``gcps=[FILE]`` (``--gcps``; a Pix4D
    coordinates file and its marks file as two), ``checkpoints=[NAME, ...]``,
    ``gcp_sigma_px``, ``gcp_vertical_offset_m``: the report's ``accuracy`` is then
    ``accuracy.json``'s. Without a ``dem`` the frames are written over the surface the
    flight's own tie points describe (the report's ``surface``); ``level_ground=True``
    (``--level-ground``) keeps the level ground."""
    o = _opts(gsd_m=gsd_m, dem=dem, adjust_positions_m=adjust_positions_m, **kwargs)
    return _aerorect.adjust_flight([os.fspath(p) for p in paths], o)


def mosaic(
    paths: Sequence[PathLike],
    out: PathLike,
    gsd_m: Optional[float] = None,
    dem: Optional[PathLike] = None,
    *,
    adjust: bool = False,
    blend: str = "feather",
    feather_px: int = 16,
    cog: bool = False,
    **kwargs: Any,
) -> dict:
    """``aerorect mosaic PATHS --out OUT``: one tiled GeoTIFF (alpha band) of the flight on one
    grid, each ground cell from its best frame, feathered at seamlines; ``adjust=True`` first
    adjusts the flight. Returns the mosaic's report."""
    o = _opts(gsd_m=gsd_m, dem=dem, cog=cog, **kwargs)
    return _aerorect.mosaic(
        [os.fspath(p) for p in paths], os.fspath(out), o, adjust, blend, feather_px
    )


from . import distributed  # noqa: E402  (stdlib only; dask is imported by the caller's client)
