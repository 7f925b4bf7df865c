"""Whole flights on a Dask cluster: the files ``aerorect batch`` writes, one task per frame.

    from dask.distributed import Client
    from aerorect.distributed import rectify_flight
    client = Client("tcp://scheduler:8786")      # or LocalCluster(), dask-jobqueue, dask-kubernetes
    written = rectify_flight(photos, "s3://bucket/flight/ortho", gsd_m=0.05, client=client)

Each frame is one task (read the photo, plan its ortho from its metadata, warp, write
``OUT_DIR/STEM.tif``): the same names, pixels and georeferencing as ``aerorect batch PHOTOS
--out-dir OUT_DIR``. With ``adjust=True`` the flight's matching and joint adjustment need every
frame's tie points: each round (as ``batch --adjust`` runs them) is one task per overlapping
pair (render both frames on the matching grid, match them), then the adjustment as one task;
then one task per frame writes it with its adjusted orientation to a staging folder in
``OUT_DIR``, and when every frame is written they are moved into ``OUT_DIR`` with
``adjustment.json`` and ``adjusted_poses.csv`` (+ ``.prj``), the same files as ``batch
--adjust`` (tie points and poses to the bit: every step is a pure function of the photos, the
options and the round's orientation, which travel between workers exactly).

Paths may be fsspec URLs (``s3://``, ``gs://``, ``abfs://``...; ``fsspec`` and the protocol's
package installed on the workers): a worker copies the photo (and the DEM, camera file or pose
table) to a local scratch folder, rectifies there and uploads the outputs.
"""

from __future__ import annotations

import json
import os
from concurrent.futures import ThreadPoolExecutor
from typing import Any, List, Optional, Sequence, Tuple

from . import AerorectError, AerorectFileError, _aerorect, _opts
from ._distributed_files import (_Local, _exists, _is_url, _join, _local_options, _stem,
                                 _with_extension)
from ._distributed_flight import ADJUSTMENT_FILES, _adjusted, _adjusted_on

__all__ = ["rectify_flight", "mosaic", "output_paths"]


def output_paths(paths: Sequence[str], out_dir: str, format: str = "tif") -> List[str]:
    """Where ``aerorect batch`` writes each photo: ``OUT_DIR/STEM.FORMAT``; two photos that
    would share an output are refused (as batch refuses them)."""
    outs = [_join(out_dir, _with_extension(_stem(os.fspath(p)), format)) for p in paths]
    first: dict = {}
    for p, o in zip(paths, outs):
        key = o if _is_url(o) else os.path.abspath(o)
        if key in first:
            raise AerorectError(
                f"{first[key]} and {p} would both be written to {o}: rename one, or rectify "
                "them in separate runs; nothing written"
            )
        first[key] = p
    return outs

def _rectify_one(photo: str, out: str, opts: dict) -> Tuple[str, Optional[str]]:
    """One frame (a task): `(out, None)` when written, `(photo, message)` when it failed."""
    local = _Local()
    try:
        o = _local_options(opts, local)
        lout = local.output(out)
        if _is_url(out):
            os.makedirs(os.path.dirname(lout), exist_ok=True)
        # The pose table is matched by the photo's file name: keep it.
        _aerorect.rectify_photo_to_file(local.input(photo), lout, o)
        local.upload(lout, out)
        return out, None
    except (AerorectError, AerorectFileError) as e:
        return photo, str(e)
    finally:
        local.close()

def rectify_flight(
    paths: Sequence[Any],
    out_dir: Any,
    gsd_m: Optional[float] = None,
    dem: Optional[Any] = None,
    adjust: bool = False,
    client: Any = None,
    *,
    format: str = "tif",
    force: bool = False,
    jobs: int = 2,
    **kwargs: Any,
) -> List[str]:
    """Rectify a flight as ``aerorect batch PATHS --out-dir OUT_DIR`` does, on a Dask client.

    One task per frame writes ``OUT_DIR/STEM.tif`` (``format="png"``: PNG + world file);
    outputs that exist are skipped unless ``force``; frames that fail are listed in the
    :class:`AerorectError` raised at the end, after every other frame is written. With
    ``adjust=True`` (``batch --adjust``) each matching round is one task per overlapping pair
    and the adjustment one task, then every frame one task; the frames, ``adjustment.json``
    and ``adjusted_poses.csv`` land together or not at all.
    Without a client the frames run here, ``jobs`` at a time (threads: the GIL is released).
    Keyword arguments as :func:`aerorect.rectify_photo` (``crs``, ``camera``, ``poses``,
    ``ground_height_m``, ``interp``, ``nodata``, ``cog``, ``adjust_positions_m``...).

    Returns every frame's output path, in the order of ``paths`` (those skipped because they
    existed included; with ``adjust``: then ``adjustment.json``, ``adjusted_poses.csv`` and
    its ``.prj``).
    """
    if format not in ("tif", "png"):
        raise AerorectError(f"--format '{format}': expected tif or png")
    if kwargs.get("cog") and format != "tif":
        raise AerorectError(
            f"--cog writes cloud-optimised GeoTIFFs: it needs --format tif, not '{format}'"
        )
    if jobs < 1:
        raise AerorectError(f"--jobs {jobs}: at least one frame must be in flight")
    photos = [os.fspath(p) for p in paths]
    out_dir = os.fspath(out_dir)
    outs = output_paths(photos, out_dir, format)
    opts = _opts(gsd_m=gsd_m, dem=dem, **kwargs)
    opts.pop("alpha", None)  # batch writes no alpha band
    if not _is_url(out_dir):
        os.makedirs(out_dir, exist_ok=True)
    if adjust:
        if client is None:
            _adjusted(photos, outs, out_dir, opts)
        else:
            _adjusted_on(client, photos, outs, out_dir, opts)
        return outs + [_join(out_dir, f) for f in ADJUSTMENT_FILES]
    todo = [(p, o) for p, o in zip(photos, outs) if force or not _exists(o)]
    if client is None:
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            results = list(pool.map(lambda po: _rectify_one(po[0], po[1], opts), todo))
    else:
        futures = [
            client.submit(_rectify_one, p, o, opts, pure=False) for p, o in todo
        ]
        results = client.gather(futures)
    failed = [(p, why) for p, why in results if why is not None]
    if failed:
        lines = "\n".join(f"failed: {p}: {why}" for p, why in failed)
        raise AerorectError(
            f"{len(failed)} of {len(photos)} frames failed (listed below)\n{lines}"
        )
    return outs


# Each worker plans a mosaic once (every photo is read for its size) and renders its tiles.
_PLANS: dict = {}


def _plan(photos: Tuple[str, ...], opts_json: str, blend: str, feather_px: int):
    key = (photos, opts_json, blend, feather_px)
    if key not in _PLANS:
        _PLANS.clear()  # one mosaic at a time per worker
        _PLANS[key] = _aerorect.plan_mosaic(list(photos), json.loads(opts_json), blend,
                                            feather_px)
    return _PLANS[key]


def _render(photos: Tuple[str, ...], opts_json: str, blend: str, feather_px: int,
            indices: List[int]):
    """Tiles `indices` of the mosaic (a task): (arrays, cells per frame)."""
    return _plan(photos, opts_json, blend, feather_px).render(indices)


def _mosaic_whole(photos, out, opts, blend, feather_px, cog):
    from . import mosaic as whole

    return whole(photos, out, adjust=True, blend=blend, feather_px=feather_px, cog=cog, **opts)


def mosaic(
    paths: Sequence[Any],
    out: Any,
    gsd_m: Optional[float] = None,
    dem: Optional[Any] = None,
    adjust: bool = False,
    client: Any = None,
    *,
    blend: str = "feather",
    feather_px: int = 16,
    tiles_per_task: int = 4,
    jobs: int = 2,
    **kwargs: Any,
) -> dict:
    """``aerorect mosaic PATHS --out OUT`` on a Dask client, one task per ``tiles_per_task``
    output tiles (512 px, row-major: neighbours share decoded frames); the tiled GeoTIFF is
    written here as the tiles arrive, the same file the CLI writes. Each worker plans the
    mosaic once from the photos (they must be readable there, by the same paths). With
    ``adjust=True`` the adjustment and the whole mosaic are one task on one worker. Without a
    client the tiles are rendered here, ``jobs`` tasks at a time. Returns the report (frames'
    ``cells`` summed over the tasks). Local paths only."""
    photos = tuple(os.fspath(p) for p in paths)
    out = os.fspath(out)
    if _is_url(out) or any(_is_url(p) for p in photos):
        raise AerorectError("the distributed mosaic reads and writes local (or shared) paths")
    if tiles_per_task < 1:
        raise AerorectError(f"tiles_per_task {tiles_per_task}: at least one tile per task")
    opts = _opts(gsd_m=gsd_m, dem=dem, **kwargs)
    cog = bool(opts.pop("cog", False))
    if adjust or cog:
        # The adjustment needs every frame at once; a COG is composited in memory.
        if client is None:
            return _mosaic_whole(photos, out, opts, blend, feather_px, cog)
        return client.submit(_mosaic_whole, photos, out, opts, blend, feather_px, cog,
                             pure=False).result()
    opts_json = json.dumps(opts, sort_keys=True)
    plan = _aerorect.plan_mosaic(list(photos), opts, blend, feather_px)
    n = len(plan.windows)
    groups = [list(range(i, min(i + tiles_per_task, n))) for i in range(0, n, tiles_per_task)]
    if client is None:
        pool = ThreadPoolExecutor(max_workers=jobs)
        _PLANS[(photos, opts_json, blend, feather_px)] = plan
        futures = [pool.submit(_render, photos, opts_json, blend, feather_px, g)
                   for g in groups]
    else:
        pool = None
        futures = [client.submit(_render, photos, opts_json, blend, feather_px, g, pure=False)
                   for g in groups]
    where = {i: (j, k) for j, g in enumerate(groups) for k, i in enumerate(g)}
    cells = [0] * len(photos)
    done: dict = {}
    left = [len(g) for g in groups]

    def fetch(i: int):
        j, k = where[i]
        if j not in done:
            arrays, c = futures[j].result()
            done[j] = arrays
            for f, v in enumerate(c):
                cells[f] += v
            futures[j] = None  # let the task's result go
        array = done[j][k]
        left[j] -= 1
        if left[j] == 0:
            del done[j]
        return array

    try:
        fetched = plan.write(out, fetch, [])
    finally:
        if pool is not None:
            pool.shutdown(cancel_futures=True)
            _PLANS.clear()
    fetched["frames"] = [dict(f, cells=c) for f, c in zip(fetched["frames"], cells)]
    fetched["covered_cells"] = sum(cells)
    return fetched
