#!/usr/bin/env python3
"""aerorect's warp engine against OpenCV's warpPerspective on the same image and homography.

Creates its own venv (bench/.venv, opencv-python-headless + numpy) on first use, builds the
`warp_timing` example in release mode, and prints, per case, both throughputs (output Mpix/s,
median of REPEATS runs of the resampling alone), the ratio ours/OpenCV, and how far the two
outputs differ on pixels well inside the source (OpenCV 5 evaluates coordinates in f32, OpenCV 4
quantises them to 1/32 px; aerorect's default fast coordinates are within 5e-4 px of the f64 map,
so small differences are expected).

usage: python3 bench/warp_vs_opencv.py [--repeats N] [--size N] [--cases gray8/bilinear,...]
"""
import argparse, json, os, subprocess, sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402




ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402

H = np.array([[0.95, 0.08, 20.0], [-0.06, 0.9, 40.0], [5e-5, 8e-5, 1.0]])  # output -> input
STAT = "median"
INTERPS = {"nearest": cv2.INTER_NEAREST, "bilinear": cv2.INTER_LINEAR, "bicubic": cv2.INTER_CUBIC}


def make_inputs(out, n):
    scene = cv2.imread(os.path.join(ROOT, "data", "aero1.jpg"), cv2.IMREAD_COLOR)
    rgb = cv2.resize(scene, (n, n), interpolation=cv2.INTER_CUBIC)
    gray = cv2.cvtColor(rgb, cv2.COLOR_BGR2GRAY)
    files = {
        "gray8": (os.path.join(out, "gray8.png"), gray),
        "rgb8": (os.path.join(out, "rgb8.png"), rgb),
        "rgba8": (os.path.join(out, "rgba8.png"), np.dstack([rgb, 255 - gray])),
        "gray16": (os.path.join(out, "gray16.png"), gray.astype(np.uint16) * 257),
        "f32": (os.path.join(out, "f32.tif"), gray.astype(np.float32) / 255.0),
    }
    for path, img in files.values():
        cv2.imwrite(path, img)
    return files


def opencv_time(img, interp, threads, n, repeats):
    cv2.setNumThreads(threads)
    flags = INTERPS[interp] | cv2.WARP_INVERSE_MAP
    ts, out = [], None
    for _ in range(repeats):
        t = cv2.getTickCount()
        out = cv2.warpPerspective(img, H, (n, n), flags=flags, borderMode=cv2.BORDER_CONSTANT, borderValue=0)
        ts.append((cv2.getTickCount() - t) / cv2.getTickFrequency())
    return float(np.min(ts) if STAT == "min" else np.median(ts)), out


def interior_mask(n, src_n, margin=3):
    c, r = np.meshgrid(np.arange(n), np.arange(n))
    p = H @ np.stack([c.ravel(), r.ravel(), np.ones(n * n)])
    x, y = p[0] / p[2], p[1] / p[2]
    ok = (x >= margin) & (y >= margin) & (x <= src_n - 1 - margin) & (y <= src_n - 1 - margin)
    return ok.reshape(n, n)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=30)
    ap.add_argument("--size", type=int, default=1024)
    ap.add_argument("--cases", default="", help="comma-separated subset, e.g. gray8/bilinear,rgb8/bilinear")
    ap.add_argument("--stat", choices=["median", "min"], default="median",
                    help="min: the fastest run of each side (less sensitive to a busy machine)")
    args = ap.parse_args()
    global STAT
    STAT = args.stat
    out = os.path.join(HERE, "out")
    os.makedirs(out, exist_ok=True)
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect", "--example", "warp_timing"], cwd=ROOT)
    exe = os.path.join(ROOT, "target", "release", "examples", "warp_timing")
    files = make_inputs(out, args.size)
    mask = interior_mask(args.size, args.size)
    hs = ",".join(repr(float(v)) for v in H.ravel())
    mpix = args.size * args.size / 1e6
    print(f"cv2 {cv2.__version__}, {args.size} x {args.size} output, {STAT} of {args.repeats} runs, cpu cores {os.cpu_count()}")
    print(f"{'case':<20}{'thr':>4}{'aerorect Mpix/s':>17}{'OpenCV Mpix/s':>15}{'ratio':>8}{'mean|diff|':>12}{'max|diff|':>11}")
    rows = []
    for name, (path, img) in files.items():
        for interp in INTERPS:
            if args.cases and f"{name}/{interp}" not in args.cases.split(","):
                continue
            for threads in (1, 2):
                # PNG for integer samples: OpenCV reads a 4-band TIFF's colour as premultiplied by alpha
                res = os.path.join(out, f"ours_{name}_{interp}" + (".tif" if name == "f32" else ".png"))
                line = subprocess.check_output([exe, path, res, hs, str(args.size), str(args.size), interp, str(threads), str(args.repeats)])
                ours = json.loads(line)[f"{STAT}_s"]
                theirs, ref = opencv_time(img, interp, threads, args.size, args.repeats)
                mine = cv2.imread(res, cv2.IMREAD_UNCHANGED)
                d = np.abs(mine.astype(np.float64) - ref.astype(np.float64))
                d = d[mask] if d.ndim == 2 else d[mask].ravel()
                scale = 255.0 if name == "f32" else 1.0  # f32 diffs in gray levels
                row = (name + "/" + interp, threads, mpix / ours, mpix / theirs, theirs / ours, d.mean() * scale, d.max() * scale)
                rows.append(row)
                print(f"{row[0]:<20}{threads:>4}{row[2]:>17.1f}{row[3]:>15.1f}{row[4]:>8.2f}{row[5]:>12.3f}{row[6]:>11.2f}")
    with open(os.path.join(out, "warp_vs_opencv.json"), "w") as f:
        json.dump([dict(zip(["case", "threads", "aerorect_mpix_s", "opencv_mpix_s", "ratio", "mean_abs_diff", "max_abs_diff"], r)) for r in rows], f, indent=1)


if __name__ == "__main__":
    main()
