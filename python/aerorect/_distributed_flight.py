"""The adjusted flight on a Dask cluster: each worker's flight plan, the matching rounds' and
the frames' tasks, and the staging that lands the frames with ``adjustment.json`` together."""

from __future__ import annotations

import json
import os
import threading
import uuid
from typing import List, Tuple

from . import AerorectError, AerorectFileError, _aerorect
from ._distributed_files import (_Local, _is_url, _join, _local_options, _move, _put_text,
                                 _remove_tree, _sidecars)

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


def _flight(photos: Tuple[str, ...], opts_json: str, roll=None):
    """The worker's plan of the flight; `roll`: the senseFly roll reading the first round
    chose (`_flight_roll`), so that every later task reads the roll that way."""
    key = (photos, opts_json, roll)
    with _FLIGHTS_LOCK:
        if key not in _FLIGHTS:
            for _, old in _FLIGHTS.values():
                old.close()
            _FLIGHTS.clear()  # one flight at a time per worker
            local = _Local()
            try:
                o = _local_options(json.loads(opts_json), local)
                plan = _aerorect.FlightPlan([local.input(p) for p in photos], o, roll)
            except BaseException:
                local.close()
                raise
            _FLIGHTS[key] = (plan, local)
        return _FLIGHTS[key][0]


def _flight_pairs(photos, opts_json, progress, roll=None):
    """The overlapping pairs of a round (a task)."""
    return _flight(photos, opts_json, roll).pairs(progress)


def _flight_pair(pair, photos, opts_json, progress, roll=None):
    """One pair rendered and matched (a task): its tie points, exact JSON."""
    return _flight(photos, opts_json, roll).pair_match(pair[0], pair[1], progress)


def _flight_feature_pairs(photos, opts_json):
    """The pairs to match by features (a task)."""
    return _flight(photos, opts_json).feature_pairs()


def _flight_features(k, photos, opts_json):
    """Frame k's features (a task): exact JSON."""
    return _flight(photos, opts_json).frame_features(k)


def _flight_feature_steps(photos, opts_json):
    """Which step matches each feature pair, 1 or 2 (a task)."""
    return _flight(photos, opts_json).feature_steps()


def _flight_feature_match(pair, first, second, photos, opts_json, guide=None,
                          first_step=False):
    """One pair matched by its features (a task): its tie points, exact JSON."""
    return _flight(photos, opts_json).feature_match(pair[0], pair[1], first, second, guide,
                                                    first_step)


def _flight_step_guide(photos, opts_json, first):
    """The first step's solve (a task on one worker): exact JSON, or None."""
    return _flight(photos, opts_json).step_guide(list(first))


def _flight_step_features(k, features, guide, photos, opts_json):
    """Frame k's features on the ground by the first step's solve (a task): exact JSON."""
    return _flight(photos, opts_json).step_features(k, features, guide)


def _flight_first_round(matches):
    """The feature matches as the first round takes them (all, or none when no pair ties)."""
    return _aerorect.FlightPlan.first_round(list(matches))


def _flight_roll(photos, opts_json, matches):
    """The senseFly roll reading the first round's feature matches agree with (a task on one
    worker): the choice's exact JSON, or None when the flight does not leave it open."""
    return _flight(photos, opts_json).choose_sensefly_roll(list(matches))


def _flight_adjust(photos, opts_json, progress, matches, roll=None, guide=None):
    """A round's adjustment (a task on one worker): (progress, done, report, poses CSV); the
    first round starts from the first step's solve (`guide`) when there were two steps."""
    return _flight(photos, opts_json, roll).adjust(progress, list(matches), guide)


def _flight_write(k, out, photos, opts_json, progress, roll=None):
    """Frame k with the adjusted orientation (a task): `(k, None)`, or `(k, message)`."""
    local = _Local()
    try:
        lout = local.output(out)
        if _is_url(out):
            os.makedirs(os.path.dirname(lout), exist_ok=True)
        _flight(photos, opts_json, roll).write_frame(k, progress, lout)
        local.upload(lout, out)
        return k, None
    except (AerorectError, AerorectFileError) as e:
        return k, str(e)
    finally:
        local.close()

def _shared(client, value):
    """`value` scattered to every worker, for a `client.map` keyword: distributed makes a
    keyword over 100 kB a graph node keyed by the keyword's own name ("progress"), which the
    scheduler refuses (`AssertionError: <TaskState 'progress' processing>`); a progress with a
    tie surface (200 kB for two DJI frames) or a thousand frames' poses is that large."""
    return client.scatter(value, broadcast=True) if value is not None else None


def _adjusted_on(client, photos: List[str], outs: List[str], out_dir: str, opts: dict) -> dict:
    """The adjusted flight as tasks: per round one per pair and the adjustment, then one per
    frame written to a staging folder; everything moved into `out_dir` when all succeeded.
    Returns the report, with `tasks`: the pair and frame tasks run."""
    key = (tuple(photos), json.dumps(opts, sort_keys=True))
    progress, done, pair_tasks, guide = None, False, 0, None
    # The first round: features per frame, matches per pair (no attitude needed).
    fpairs = client.submit(_flight_feature_pairs, *key, pure=False).result()
    features: List[str] = []
    if fpairs:
        feats = client.map(_flight_features, range(len(photos)), photos=key[0],
                           opts_json=key[1], pure=False)
        # Two steps when the priors cannot guide a large flight (as adjust_flight): a net
        # of pairs matched and solved first, the rest guided by that solve.
        steps = client.submit(_flight_feature_steps, *key, pure=False).result()
        first = [p for p, s in zip(fpairs, steps) if s == 1]
        second = [p for p, s in zip(fpairs, steps) if s == 2]
        fmatches = [client.submit(_flight_feature_match, tuple(p), feats[p[0]], feats[p[1]],
                                  *key, None, bool(second), pure=False) for p in first]
        if second:
            guide = client.submit(_flight_step_guide, *key, fmatches, pure=False).result()
            # Scattered once (every second-step task takes it), not copied into each task.
            shared = _shared(client, guide)
            if guide is not None:
                feats = [client.submit(_flight_step_features, k, f, shared, *key, pure=False)
                         for k, f in enumerate(feats)]
            later = iter([client.submit(_flight_feature_match, tuple(p), feats[p[0]],
                                        feats[p[1]], *key, shared, pure=False) for p in second])
            earlier = iter(fmatches)
            fmatches = [next(earlier) if s == 1 else next(later) for s in steps]
        pair_tasks += len(fmatches)
        features = client.submit(_flight_first_round, fmatches, pure=False).result()
        del feats, fmatches
    roll = None
    if features:
        # senseFly's roll sign, when the flight leaves it to its images (as adjust_flight).
        roll = client.submit(_flight_roll, *key, features, pure=False).result()
        step = client.submit(_flight_adjust, *key, progress, features, roll=roll, guide=guide,
                             pure=False)
        progress, done, report_json, poses_csv = step.result()
    # Later rounds: correlation of the rendered frames, the feature ties kept beside it.
    while not done:
        pairs = client.submit(_flight_pairs, *key, progress, roll=roll, pure=False).result()
        matches = client.map(_flight_pair, [tuple(p) for p in pairs], photos=key[0],
                             opts_json=key[1], progress=_shared(client, progress), roll=roll,
                             pure=False)
        pair_tasks += len(matches)
        step = client.submit(_flight_adjust, *key, progress, matches + features, roll=roll,
                             pure=False)
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
                                           progress=_shared(client, progress), roll=roll,
                                           pure=False))
        failed = [(photos[k], why) for k, why in written if why is not None]
        if failed:
            lines = "\n".join(f"failed: {p}: {why}" for p, why in failed)
            raise AerorectError(
                f"{len(failed)} of {len(photos)} frames failed (listed below); nothing "
                f"written: the adjusted frames and adjustment.json land together\n{lines}"
            )
        wkt = client.submit(_flight_crs, *key, roll=roll, pure=False).result()
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


def _flight_crs(photos, opts_json, roll=None):
    return _flight(photos, opts_json, roll).crs_wkt()
