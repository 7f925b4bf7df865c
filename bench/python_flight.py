"""The Python package's costs: call overhead against the CLI on one frame, a whole simulated
flight on a Dask LocalCluster with 1 and 2 workers (frames/s, peak memory per worker), and the
memory one frame of a given size needs.

Run with the test environment scripts/test-all.sh makes (it has aerorect, rasterio, dask):

    target/pyenv/bin/python bench/python_flight.py [--frames 200] [--side 2000] [--out bench/out/python_flight.json]

Frames are the bundled data/aero1.jpg resampled to SIDE x 3/4 SIDE (GDAL's JPEG encoder) with
DJI tags (CalibratedFocalLength scaled with it) on a grid of positions, nadir +-10 degrees of
yaw: synthetic, but every frame is a real decode, plan, warp and GeoTIFF write.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import rasterio
from rasterio.enums import Resampling

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "python" / "tests"))
from conftest import jpeg_with_xmp, xmp  # noqa: E402

import aerorect  # noqa: E402
from aerorect.distributed import rectify_flight  # noqa: E402


def base_jpeg(dir_: Path, side: int) -> Path:
    with rasterio.open(ROOT / "data" / "aero1.jpg") as src:
        a = src.read(out_shape=(3, side * 3 // 4, side), resampling=Resampling.bilinear)
    p = dir_ / f"base{side}.jpg"
    with rasterio.open(p, "w", driver="JPEG", width=a.shape[2], height=a.shape[1], count=3,
                       dtype="uint8", QUALITY=90) as dst:
        dst.write(a)
    return p


def flight(dir_: Path, n: int, side: int) -> list[Path]:
    base = base_jpeg(dir_, side)
    f = 500.0 * side / 640
    out = []
    for k in range(n):
        r, c = divmod(k, 20)
        packet = xmp(53.9 + r * 0.0002, 27.55 + c * 0.0003, yaw=(7 * k) % 20 - 10,
                     pitch=-90 + (k % 5), focal_px=f)
        out.append(jpeg_with_xmp(dir_ / f"DJI_{k:04d}.JPG", packet, source=base))
    return out


def overhead(dir_: Path, side: int, reps: int) -> dict:
    (dir_ / f"one{side}").mkdir()
    p = flight(dir_ / f"one{side}", 1, side)[0]
    cli = os.environ.get("AERORECT_BIN", str(ROOT / "target" / "release" / "aerorect"))
    t_cli, t_file, t_mem = [], [], []
    for _ in range(reps):
        t = time.perf_counter()
        subprocess.run([cli, "rectify", str(p), str(dir_ / "cli.tif")], check=True,
                       capture_output=True)
        t_cli.append(time.perf_counter() - t)
        t = time.perf_counter()
        aerorect.rectify_photo_to_file(p, dir_ / "py.tif")
        t_file.append(time.perf_counter() - t)
        t = time.perf_counter()
        aerorect.rectify_photo(p)
        t_mem.append(time.perf_counter() - t)
    assert (dir_ / "cli.tif").read_bytes() == (dir_ / "py.tif").read_bytes()
    med = lambda v: round(statistics.median(v) * 1000, 1)  # noqa: E731
    return {"frame_px": [side, side * 3 // 4], "reps": reps, "cli_ms": med(t_cli),
            "python_to_file_ms": med(t_file), "python_in_memory_ms": med(t_mem)}


def peak_rss_mb() -> float:
    """This process's peak resident memory (Linux VmHWM: unlike ru_maxrss it is not inherited
    from the parent across fork + exec)."""
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmHWM:"):
            return int(line.split()[1]) / 1024.0
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def one_frame_memory(dir_: Path, side: int) -> dict:
    """Peak RSS of a fresh process that imports aerorect, then rectifies one frame."""
    (dir_ / f"mem{side}").mkdir()
    p = flight(dir_ / f"mem{side}", 1, side)[0]
    code = ("import sys,aerorect;"
            "hwm=lambda:[int(l.split()[1]) for l in open('/proc/self/status') if l.startswith('VmHWM:')][0];"
            "b=hwm();aerorect.rectify_photo_to_file(sys.argv[1], sys.argv[2]);"
            "a=hwm();print(b/1024,a/1024)")
    out = subprocess.run([sys.executable, "-c", code, str(p), str(dir_ / f"mem{side}.tif")],
                         check=True, capture_output=True, text=True).stdout.split()
    before, after = float(out[0]), float(out[1])
    return {"frame_px": [side, side * 3 // 4], "rss_after_import_mb": round(before, 1),
            "peak_rss_mb": round(after, 1), "frame_needs_mb": round(after - before, 1)}


def cluster_run(photos: list[Path], out: Path, workers: int) -> dict:
    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      dashboard_address=None) as cluster, Client(cluster) as client:
        base = client.run(peak_rss_mb)
        t = time.perf_counter()
        written = rectify_flight(photos, out, client=client)
        dt = time.perf_counter() - t
        peak = client.run(peak_rss_mb)
    assert len(written) == len(photos)
    return {"workers": workers, "frames": len(photos), "seconds": round(dt, 2),
            "frames_per_s": round(len(photos) / dt, 2),
            "worker_rss_before_mb": sorted(round(v, 1) for v in base.values()),
            "worker_peak_rss_mb": sorted(round(v, 1) for v in peak.values())}


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--frames", type=int, default=200)
    ap.add_argument("--side", type=int, default=2000)
    ap.add_argument("--reps", type=int, default=7)
    ap.add_argument("--out", default=str(ROOT / "bench" / "out" / "python_flight.json"))
    a = ap.parse_args()
    tmp = Path(tempfile.mkdtemp(prefix="aerorect-bench-"))
    try:
        res = {"cpus": os.cpu_count(), "overhead": [overhead(tmp, s, a.reps) for s in (640, a.side)],
               "one_frame_memory": [one_frame_memory(tmp, s) for s in (a.side, 4000)]}
        print(json.dumps(res, indent=1), flush=True)
        (tmp / "flight").mkdir()
        photos = flight(tmp / "flight", a.frames, a.side)
        cli = os.environ.get("AERORECT_BIN", str(ROOT / "target" / "release" / "aerorect"))
        t = time.perf_counter()
        subprocess.run([cli, "batch", *map(str, photos), "--out-dir", str(tmp / "cli")],
                       check=True, capture_output=True)
        dt = time.perf_counter() - t
        res["cli_batch"] = {"frames": a.frames, "jobs": 2, "seconds": round(dt, 2),
                            "frames_per_s": round(a.frames / dt, 2)}
        res["local_cluster"] = []
        for w in (1, 2):
            r = cluster_run(photos, tmp / f"dask{w}", w)
            same = all((tmp / f"dask{w}" / n).read_bytes() == (tmp / "cli" / n).read_bytes()
                       for n in os.listdir(tmp / "cli"))
            r["files_equal_to_cli_batch"] = same
            res["local_cluster"].append(r)
            print(json.dumps(r), flush=True)
        Path(a.out).parent.mkdir(parents=True, exist_ok=True)
        Path(a.out).write_text(json.dumps(res, indent=1) + "\n")
        print(json.dumps(res, indent=1))
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    main()
