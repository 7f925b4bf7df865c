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
import shutil
import tempfile
import threading
import uuid
from concurrent.futures import ThreadPoolExecutor
from typing import Any, List, Optional, Sequence, Tuple

from . import AerorectError, AerorectFileError, _aerorect, _opts

__all__ = ["rectify_flight", "mosaic", "output_paths"]

# Options that name files a worker must be able to read.
_FILE_OPTIONS = ("dem", "camera", "poses")


def _is_url(p: str) -> bool:
    return "://" in p and not p.startswith("file://")


def _join(base: str, name: str) -> str:
    return base.rstrip("/") + "/" + name if _is_url(base) else os.path.join(base, name)


def _stem(p: str) -> str:
    name = p.rstrip("/").rsplit("/", 1)[-1]
    name = os.path.basename(name)
    dot = name.rfind(".")
    return name[:dot] if dot > 0 else name


def _with_extension(name: str, ext: str) -> str:
    """Rust's Path::with_extension on a file name (batch names its outputs so)."""
    dot = name.rfind(".")
    return (name[:dot] if dot > 0 else name) + "." + ext


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


def _sidecars(path: str) -> List[str]:
    """An output and its sidecars (PNG: world file, .prj, .aux.xml)."""
    if path.lower().endswith(".png"):
        base = path[: -len(".png")]
        return [path, base + ".pgw", base + ".prj", path + ".aux.xml"]
    return [path]


class _Local:
    """Local copies of URL inputs and a scratch folder for URL outputs (one per task)."""

    def __init__(self) -> None:
        self.dir: Optional[str] = None

    def scratch(self) -> str:
        if self.dir is None:
            self.dir = tempfile.mkdtemp(prefix="aerorect-")
        return self.dir

    def input(self, p: str) -> str:
        if not _is_url(p):
            return p
        import fsspec

        local = os.path.join(self.scratch(), "in", os.path.basename(p.rstrip("/")))
        os.makedirs(os.path.dirname(local), exist_ok=True)
        fs, path = fsspec.core.url_to_fs(p)
        fs.get(path, local)
        prj = path.rsplit(".", 1)[0] + ".prj"
        if fs.exists(prj):  # a pose table's CRS
            fs.get(prj, local.rsplit(".", 1)[0] + ".prj")
        return local

    def output(self, p: str) -> str:
        if not _is_url(p):
            return p
        return os.path.join(self.scratch(), "out", os.path.basename(p.rstrip("/")))

    def upload(self, local: str, url: str) -> None:
        if not _is_url(url):
            return
        import fsspec

        fs, path = fsspec.core.url_to_fs(url)
        for lf, rf in zip(_sidecars(local), _sidecars(path)):
            if os.path.exists(lf):
                fs.put(lf, rf)

    def close(self) -> None:
        if self.dir is not None:
            shutil.rmtree(self.dir, ignore_errors=True)


def _local_options(opts: dict, local: _Local) -> dict:
    return {k: (local.input(v) if k in _FILE_OPTIONS else v) for k, v in opts.items()}


def _exists(p: str) -> bool:
    if _is_url(p):
        import fsspec

        fs, path = fsspec.core.url_to_fs(p)
        return fs.exists(path)
    return os.path.exists(p)


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


# What `batch --adjust` writes beside the frames.
ADJUSTMENT_FILES = ("adjustment.json", "adjusted_poses.csv", "adjusted_poses.prj")


def _adjusted(photos: List[str], outs: List[str], out_dir: str, opts: dict) -> dict:
    """The whole adjusted flight (a task on one worker)."""
    local = _Local()
    try:
        o = _local_options(opts, local)
        lphotos = [local.input(p) for p in photos]
        louts = [local.output(p) for p in outs]
        ldir = os.path.join(local.scratch(), "out") if _is_url(out_dir) else out_dir
        os.makedirs(ldir, exist_ok=True)
        r = _aerorect.write_adjusted_batch(lphotos, louts, ldir, o)
        extra = [os.path.join(ldir, f) for f in ADJUSTMENT_FILES]
        urls = [_join(out_dir, f) for f in ADJUSTMENT_FILES]
        for lf, url in zip(louts + extra, outs + urls):
            local.upload(lf, url)
        return r
    finally:
        local.close()


# Each worker plans an adjusted flight once (every photo is read) and runs its steps.
_FLIGHTS: dict = {}
_FLIGHTS_LOCK = threading.Lock()


def _flight(photos: Tuple[str, ...], opts_json: str):
    key = (photos, opts_json)
    with _FLIGHTS_LOCK:
        if key not in _FLIGHTS:
            for _, old in _FLIGHTS.values():
                old.close()
            _FLIGHTS.clear()  # one flight at a time per worker
            local = _Local()
            try:
                o = _local_options(json.loads(opts_json), local)
                plan = _aerorect.FlightPlan([local.input(p) for p in photos], o)
            except BaseException:
                local.close()
                raise
            _FLIGHTS[key] = (plan, local)
        return _FLIGHTS[key][0]


def _flight_pairs(photos, opts_json, progress):
    """The overlapping pairs of a round (a task)."""
    return _flight(photos, opts_json).pairs(progress)


def _flight_pair(pair, photos, opts_json, progress):
    """One pair rendered and matched (a task): its tie points, exact JSON."""
    return _flight(photos, opts_json).pair_match(pair[0], pair[1], progress)


def _flight_feature_pairs(photos, opts_json):
    """The pairs to match by features (a task)."""
    return _flight(photos, opts_json).feature_pairs()


def _flight_features(k, photos, opts_json):
    """Frame k's features (a task): exact JSON."""
    return _flight(photos, opts_json).frame_features(k)


def _flight_feature_match(pair, first, second, photos, opts_json):
    """One pair matched by its features (a task): its tie points, exact JSON."""
    return _flight(photos, opts_json).feature_match(pair[0], pair[1], first, second)


def _flight_first_round(matches):
    """The feature matches as the first round takes them (all, or none when no pair ties)."""
    return _aerorect.FlightPlan.first_round(list(matches))


def _flight_adjust(photos, opts_json, progress, matches):
    """A round's adjustment (a task on one worker): (progress, done, report, poses CSV)."""
    return _flight(photos, opts_json).adjust(progress, list(matches))


def _flight_write(k, out, photos, opts_json, progress):
    """Frame k with the adjusted orientation (a task): `(k, None)`, or `(k, message)`."""
    local = _Local()
    try:
        lout = local.output(out)
        if _is_url(out):
            os.makedirs(os.path.dirname(lout), exist_ok=True)
        _flight(photos, opts_json).write_frame(k, progress, lout)
        local.upload(lout, out)
        return k, None
    except (AerorectError, AerorectFileError) as e:
        return k, str(e)
    finally:
        local.close()


def _put_text(path: str, text: str) -> None:
    if _is_url(path):
        import fsspec

        fs, p = fsspec.core.url_to_fs(path)
        fs.pipe(p, text.encode())
    else:
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)


def _move(src: str, dst: str) -> bool:
    if _is_url(src):
        import fsspec

        fs, s = fsspec.core.url_to_fs(src)
        if not fs.exists(s):
            return False
        fs.mv(s, fsspec.core.url_to_fs(dst)[1])
        return True
    if not os.path.exists(src):
        return False
    os.replace(src, dst)
    return True


def _remove_tree(path: str) -> None:
    if _is_url(path):
        import fsspec

        fs, p = fsspec.core.url_to_fs(path)
        if fs.exists(p):
            fs.rm(p, recursive=True)
    else:
        shutil.rmtree(path, ignore_errors=True)


def _adjusted_on(client, photos: List[str], outs: List[str], out_dir: str, opts: dict) -> dict:
    """The adjusted flight as tasks: per round one per pair and the adjustment, then one per
    frame written to a staging folder; everything moved into `out_dir` when all succeeded.
    Returns the report, with `tasks`: the pair and frame tasks run."""
    key = (tuple(photos), json.dumps(opts, sort_keys=True))
    progress, done, pair_tasks = None, False, 0
    # The first round: features per frame, matches per pair (no attitude needed).
    fpairs = client.submit(_flight_feature_pairs, *key, pure=False).result()
    features: List[str] = []
    if fpairs:
        feats = client.map(_flight_features, range(len(photos)), photos=key[0],
                           opts_json=key[1], pure=False)
        fmatches = [client.submit(_flight_feature_match, tuple(p), feats[p[0]], feats[p[1]],
                                  *key, pure=False) for p in fpairs]
        pair_tasks += len(fmatches)
        features = client.submit(_flight_first_round, fmatches, pure=False).result()
        del feats, fmatches
    if features:
        step = client.submit(_flight_adjust, *key, progress, features, pure=False)
        progress, done, report_json, poses_csv = step.result()
    # Later rounds: correlation of the rendered frames, the feature ties kept beside it.
    while not done:
        pairs = client.submit(_flight_pairs, *key, progress, pure=False).result()
        matches = client.map(_flight_pair, [tuple(p) for p in pairs], photos=key[0],
                             opts_json=key[1], progress=progress, pure=False)
        pair_tasks += len(matches)
        step = client.submit(_flight_adjust, *key, progress, matches + features, pure=False)
        progress, done, report_json, poses_csv = step.result()
        del matches, step
    stage = _join(out_dir, ".aerorect-staging-" + uuid.uuid4().hex)
    if not _is_url(stage):
        os.makedirs(stage)
    try:
        staged = [_join(stage, o.rstrip("/").rsplit("/", 1)[-1].rsplit(os.sep, 1)[-1])
                  for o in outs]
        written = client.gather(client.map(_flight_write, range(len(photos)), staged,
                                           photos=key[0], opts_json=key[1],
                                           progress=progress, pure=False))
        failed = [(photos[k], why) for k, why in written if why is not None]
        if failed:
            lines = "\n".join(f"failed: {p}: {why}" for p, why in failed)
            raise AerorectError(
                f"{len(failed)} of {len(photos)} frames failed (listed below); nothing "
                f"written: the adjusted frames and adjustment.json land together\n{lines}"
            )
        wkt = client.submit(_flight_crs, *key, pure=False).result()
        texts = dict(zip(ADJUSTMENT_FILES, (report_json, poses_csv, wkt)))
        for name, text in texts.items():
            _put_text(_join(stage, name), text)
        for s, o in zip(staged, outs):
            for ss, oo in zip(_sidecars(s), _sidecars(o)):
                _move(ss, oo)
        for name in ADJUSTMENT_FILES:
            _move(_join(stage, name), _join(out_dir, name))
    finally:
        _remove_tree(stage)
    report = json.loads(report_json)
    report["tasks"] = {"pairs": pair_tasks, "frames": len(photos)}
    return report


def _flight_crs(photos, opts_json):
    return _flight(photos, opts_json).crs_wkt()


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
