#!/usr/bin/env python3
"""Area-aware downsampling: aerorect's average / prefiltered bilinear and bicubic against OpenCV.

A zone plate 0.5 + 0.5 cos(k r^2) (local frequency up to 0.45 cycles/px at the corners), SIZE*4
square, gray u8, is shrunk 4x to SIZE x SIZE (OpenCV resize's grid: output c reads input
4 (c + 0.5) - 0.5). Per case: median seconds of REPEATS runs of the resampling alone (THREADS
threads), and the RMS error (grey levels) against the analytic plate box-filtered over each output
pixel (4 x 4 points of the output pixel), over all pixels and over those whose local frequency is
past the output's Nyquist (0.5 cycles per output pixel: what aliasing turns into false rings).
Peers: cv2.resize INTER_AREA and INTER_LINEAR, cv2.warpPerspective INTER_LINEAR (same matrix).

usage: python3 bench/downsample_vs_peers.py [--size 1024] [--repeats 5] [--threads 1]
"""
import argparse, json, os, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402
from bench_util import median_time  # noqa: E402

ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402

F = 4


def zone_plate(x, y, n, f_max=0.45):
    c = 0.5 * (n - 1)
    k = f_max * np.pi / ((n - 1) / np.sqrt(2))
    return 0.5 + 0.5 * np.cos(k * ((x - c) ** 2 + (y - c) ** 2)), k


def truth_and_mask(n_out, n_in, s=4):
    c, r = np.meshgrid(np.arange(n_out, dtype=np.float64), np.arange(n_out, dtype=np.float64))
    acc = np.zeros_like(c)
    for j in range(s):
        for i in range(s):
            dc, dr = (i + 0.5) / s - 0.5, (j + 0.5) / s - 0.5
            v, _ = zone_plate(F * (c + dc + 0.5) - 0.5, F * (r + dr + 0.5) - 0.5, n_in)
            acc += v
    _, k = zone_plate(0.0, 0.0, n_in)
    x, y = F * (c + 0.5) - 0.5, F * (r + 0.5) - 0.5
    freq = k * np.hypot(x - 0.5 * (n_in - 1), y - 0.5 * (n_in - 1)) / np.pi * F
    return 255.0 * acc / (s * s), freq > 0.5


def errors(out, truth, high):
    d = out.astype(np.float64) - truth
    return float(np.sqrt(np.mean(d**2))), float(np.sqrt(np.mean(d[high] ** 2)))



def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--threads", type=int, default=1)
    a = ap.parse_args()
    n_out, n_in = a.size, a.size * F
    c, r = np.meshgrid(np.arange(n_in, dtype=np.float64), np.arange(n_in, dtype=np.float64))
    src = np.clip(np.floor(255.0 * zone_plate(c, r, n_in)[0] + 0.5), 0, 255).astype(np.uint8)
    truth, high = truth_and_mask(n_out, n_in)
    subprocess.check_call(
        ["cargo", "build", "--release", "-q", "-p", "aerorect-raster", "--example", "downsample_timing"],
        cwd=ROOT,
    )
    exe = os.path.join(ROOT, "target", "release", "examples", "downsample_timing")
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        src.tofile(os.path.join(tmp, "in.u8"))
        res = subprocess.run(
            [exe, os.path.join(tmp, "in.u8"), str(n_in), str(n_in), tmp, str(n_out), str(n_out),
             str(F), str(a.threads), str(a.repeats)],
            check=True, capture_output=True, text=True,
        )
        for line in res.stdout.splitlines():
            j = json.loads(line)
            out = np.fromfile(os.path.join(tmp, f"ours_{j['case']}.u8"), np.uint8).reshape(n_out, n_out)
            rows.append(("aerorect " + j["case"], j["median_s"], *errors(out, truth, high)))
    cv2.setNumThreads(a.threads)
    o = 0.5 * (F - 1)
    m = np.array([[F, 0, o], [0, F, o], [0, 0, 1]], np.float64)
    peers = {
        "cv2.resize INTER_AREA": lambda: cv2.resize(src, (n_out, n_out), interpolation=cv2.INTER_AREA),
        "cv2.resize INTER_LINEAR": lambda: cv2.resize(src, (n_out, n_out), interpolation=cv2.INTER_LINEAR),
        "cv2.warpPerspective LINEAR": lambda: cv2.warpPerspective(
            src, m, (n_out, n_out), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP),
    }
    for name, fn in peers.items():
        t, out = median_time(fn, a.repeats)
        rows.append((name, t, *errors(out, truth, high)))
    area = dict((r[0], r[1]) for r in rows)["cv2.resize INTER_AREA"]
    print(f"zone plate {n_in}^2 -> {n_out}^2 (x{F}), u8, {a.threads} thread(s), median of {a.repeats}; "
          f"cv2 {cv2.__version__}")
    print(f"{'case':34s} {'ms':>9s} {'/INTER_AREA':>11s} {'rms all':>8s} {'rms >Nyq':>9s}  (grey levels)")
    for name, t, e_all, e_high in rows:
        print(f"{name:34s} {1e3 * t:9.2f} {t / area:11.2f} {e_all:8.2f} {e_high:9.2f}")


if __name__ == "__main__":
    main()
