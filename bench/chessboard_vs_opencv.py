#!/usr/bin/env python3
"""Chessboard corners, aerorect beside OpenCV on the same photos.

1. OpenCV's own left01..14 photos (data/calib-opencv): `aerorect calibrate --images
   --save-corners` (the default window, 11 = OpenCV's cornerSubPix winSize, and --corner-window auto)
   against OpenCV's stored corners (data/calib/left_corners.csv) and calibrateCamera numbers;
   then left02 (nearly edge-on board): a camera from the other 12 views and a pose from the
   corners both tools agree on, and each tool's disputed corners against that pose.
2. Synthetic boards rendered here in numpy (pinhole + radial k1, k2; 4 x 4 sub-samples a pixel,
   Gaussian blur, Gaussian noise, 8-bit PNG) at known poses: corner error against the truth,
   aerorect's (through the CLI's --save-corners) and OpenCV's (findChessboardCorners +
   cornerSubPix winSize 11 x 11, eps 0.001, 30 iterations; and winSize 5 x 5), per noise level,
   for moderate poses and for steep, distant ones (small foreshortened squares).
Creates its own venv (bench/.venv) with opencv-python-headless and numpy.
usage: python3 bench/chessboard_vs_opencv.py [--views N]
"""
import argparse, csv, os, re, subprocess, sys, tempfile, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402

EXE = os.path.join(ROOT, "target", "release", "aerorect")
CRIT = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 30, 0.001)


def load_corners(path):
    out = {}
    for r in csv.DictReader(open(path)):
        out.setdefault(os.path.basename(r["image"]), []).append([float(r[k]) for k in "XYZuv"])
    return {k: np.array(v) for k, v in out.items()}


def run_ours(images, board, square, out_csv, extra=()):
    cmd = [EXE, "calibrate", "--images", *images, "--board", board, "--square-m", str(square),
           "--model", "opencv", "--stop-px", "1e-6", "--save-corners", out_csv, *extra]
    text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
    vals = {m[0]: float(m[1]) for m in re.findall(r"^\s+(fx|fy|cx|cy)\s+(\S+)", text, re.M)}
    vals["rms"] = float(re.search(r"^RMS (\S+)", text, re.M).group(1))
    ms = [float(x) for x in re.findall(r"corners \((\S+) ms\)", text)]
    return vals, ms


def opencv_corners(path, board, win=11):
    g = cv2.imread(path, cv2.IMREAD_GRAYSCALE)
    t = time.perf_counter()
    ok, c = cv2.findChessboardCorners(g, board)
    if ok:
        c = cv2.cornerSubPix(g, c, (win, win), (-1, -1), CRIT)
    return (c.reshape(-1, 2) if ok else None), time.perf_counter() - t


def photos_section():
    ref = load_corners(os.path.join(ROOT, "data", "calib", "left_corners.csv"))
    imgs = sorted(os.path.join(ROOT, "data", "calib-opencv", k) for k in ref)
    print("OpenCV's left01..14 (13 photos, 9 x 6); reference: OpenCV 5.0 corners, calibrateCamera "
          "fx 536.0734 fy 536.0163 cx 342.3705 cy 235.5369 RMS 0.40869")
    print(f"{'window':<22}{'found':>6}{'mean px':>10}{'max px':>9}{'fx':>10}{'fy':>10}{'cx':>10}{'cy':>10}{'RMS':>9}{'ms/img':>8}")
    ours_default = None
    with tempfile.TemporaryDirectory() as tmp:
        for label, extra in (("aerorect --corner-window auto", ("--corner-window", "auto")), ("aerorect default (11, OpenCV's)", ())):
            out = os.path.join(tmp, "c.csv")
            vals, ms = run_ours(imgs, "9x6", 0.025, out, extra)
            ours = load_corners(out)
            d = np.concatenate([np.linalg.norm(ours[k][:, 3:] - ref[k][:, 3:], axis=1) for k in ref if k in ours])
            print(f"{label:<22}{len(ours):>4}/{len(ref)}{d.mean():>10.4f}{d.max():>9.4f}{vals['fx']:>10.3f}{vals['fy']:>10.3f}"
                  f"{vals['cx']:>10.3f}{vals['cy']:>10.3f}{vals['rms']:>9.4f}{np.median(ms):>8.1f}")
            if not extra:
                ours_default = ours
        cv_ms = []
        for p in imgs:
            _, t = opencv_corners(p, (9, 6))
            cv_ms.append(t * 1e3)
        print(f"OpenCV {cv2.__version__} findChessboardCorners + cornerSubPix: median {np.median(cv_ms):.1f} ms/img")
    left02(ref, ours_default)


def left02(ref, ours):
    others = [k for k in ref if k != "left02.jpg"]
    obj = [ref[k][:, :3].astype(np.float32) for k in others]
    img = [ref[k][:, 3:].astype(np.float32) for k in others]
    _, K, D, _, _ = cv2.calibrateCamera(obj, img, (640, 480), None, None)
    a, b = ref["left02.jpg"], ours["left02.jpg"]
    d = np.linalg.norm(a[:, 3:] - b[:, 3:], axis=1)
    bad = d > 0.1
    _, rv, tv = cv2.solvePnP(np.ascontiguousarray(a[~bad, :3]), np.ascontiguousarray(a[~bad, 3:]), K, D)
    proj = cv2.projectPoints(np.ascontiguousarray(a[:, :3]), rv, tv, K, D)[0].reshape(-1, 2)
    print(f"left02: {bad.sum()} corners differ by more than 0.1 px (ids {[int(i) for i in np.where(bad)[0]]}); against the pose "
          f"fitted to the other {(~bad).sum()} with a camera from the other 12 views (fx {K[0, 0]:.2f}):")
    for name, s in (("OpenCV", a), ("aerorect", b)):
        e = np.linalg.norm(s[bad, 3:] - proj[bad], axis=1)
        print(f"  {name:<9} residuals {np.round(e, 2)} px, mean {e.mean():.3f}")


def rodrigues(r):
    return cv2.Rodrigues(np.array(r, dtype=np.float64))[0]


def render(size, K, k, R, t, cols, rows, sq, blur, noise, rng, sub=4):
    w, h = size
    off = (np.arange(sub) + 0.5) / sub - 0.5
    u = (np.arange(w)[None, :, None, None] + off[None, None, None, :]) + 0 * off[None, None, :, None]
    v = (np.arange(h)[:, None, None, None] + off[None, None, :, None]) + 0 * off[None, None, None, :]
    u, v = np.broadcast_arrays(u, v)
    xd, yd = (u - K[0, 2]) / K[0, 0], (v - K[1, 2]) / K[1, 1]
    x, y = xd.copy(), yd.copy()
    for _ in range(10):
        r2 = x * x + y * y
        f = 1 + k[0] * r2 + k[1] * r2 * r2
        x, y = xd / f, yd / f
    d = np.stack([x, y, np.ones_like(x)], -1) @ R  # R^T d, row vectors
    o = -R.T @ t
    s = -o[2] / d[..., 2]
    X, Y = o[0] + s * d[..., 0], o[1] + s * d[..., 1]
    i, j = np.floor(X / sq), np.floor(Y / sq)
    val = np.where((i + j) % 2 == 0, 30.0, 220.0)
    margin = (i == -2) | (j == -2) | (i == cols) | (j == rows)
    val = np.where(margin, 220.0, val)
    val = np.where((i < -2) | (j < -2) | (i > cols) | (j > rows) | (s <= 0), 120.0, val)
    img = val.mean(axis=(2, 3))
    img = cv2.GaussianBlur(img, (0, 0), blur)
    img = img + rng.normal(0, noise, img.shape)
    truth = []
    for r in range(rows):
        for c in range(cols):
            pc = R @ np.array([c * sq, r * sq, 0.0]) + t
            xx, yy = pc[0] / pc[2], pc[1] / pc[2]
            r2 = xx * xx + yy * yy
            f = 1 + k[0] * r2 + k[1] * r2 * r2
            truth.append([K[0, 0] * xx * f + K[0, 2], K[1, 1] * yy * f + K[1, 2]])
    return np.clip(np.rint(img), 0, 255).astype(np.uint8), np.array(truth)


def synthetic_section(views, tilt=0.6, zrange=(0.5, 0.8)):
    K = np.array([[620.0, 0, 319.5], [0, 620.0, 239.5], [0, 0, 1]])
    k = (-0.2, 0.05)
    cols, rows, sq = 9, 6, 0.03
    rng = np.random.default_rng(1)
    print(f"\nsynthetic 640 x 480, 9 x 6 board, f 620 px, k1 -0.2, k2 0.05, {views} poses a row (tilts up to {tilt} rad,"
          f" distance {zrange[0]}-{zrange[1]} m), 8-bit PNG; corner error against the truth (px)")
    print(f"{'blur':>5}{'noise':>6} | {'ours found':>10}{'mean':>8}{'rms':>8}{'max':>8} | {'OpenCV found':>12}{'mean':>8}{'rms':>8}{'max':>8} | both-found mean ours/OpenCV | OpenCV winSize 5x5 mean, max")
    for blur, noise in ((0.8, 0.0), (0.8, 2.0), (0.8, 5.0), (1.5, 5.0), (1.5, 10.0)):
        with tempfile.TemporaryDirectory() as tmp:
            paths, truths = [], {}
            while len(paths) < views:
                rv = rng.uniform(-tilt, tilt, 3) * np.array([1, 1, 0.5])
                R = rodrigues(rv)
                z = rng.uniform(*zrange)
                centre = np.array([(cols - 1) * sq / 2, (rows - 1) * sq / 2, 0])
                t = np.array([rng.uniform(-0.05, 0.05), rng.uniform(-0.04, 0.04), z]) - R @ centre
                img, truth = render((640, 480), K, k, R, t, cols, rows, sq, blur, noise, rng)
                if truth[:, 0].min() < 15 or truth[:, 0].max() > 625 or truth[:, 1].min() < 15 or truth[:, 1].max() > 465:
                    continue
                p = os.path.join(tmp, f"v{len(paths):02d}.png")
                cv2.imwrite(p, img)
                paths.append(p)
                truths[os.path.basename(p)] = truth
            out = os.path.join(tmp, "c.csv")
            try:
                run_ours(paths, "9x6", sq, out)
                ours = {k2: v[:, 3:] for k2, v in load_corners(out).items()}
            except subprocess.CalledProcessError as e:
                print("aerorect failed:", e.stdout[-300:], e.stderr[-300:])
                ours = {}
            theirs, small = {}, {}
            for p in paths:
                c, _ = opencv_corners(p, (cols, rows))
                if c is not None:
                    theirs[os.path.basename(p)] = c
                c, _ = opencv_corners(p, (cols, rows), win=5)
                if c is not None:
                    small[os.path.basename(p)] = c

            def err(found):
                e = [np.linalg.norm(found[n] - truths[n], axis=1) for n in found]
                return np.concatenate(e) if e else np.array([np.nan])
            eo, ec, es = err(ours), err(theirs), err(small)
            both = [n for n in ours if n in theirs]
            bo = np.concatenate([np.linalg.norm(ours[n] - truths[n], axis=1) for n in both]) if both else np.array([np.nan])
            bc = np.concatenate([np.linalg.norm(theirs[n] - truths[n], axis=1) for n in both]) if both else np.array([np.nan])
            rms = lambda e: np.sqrt(np.nanmean(e ** 2))  # noqa: E731
            print(f"{blur:>5}{noise:>6} | {len(ours):>6}/{views:<3}{np.nanmean(eo):>8.4f}{rms(eo):>8.4f}{np.nanmax(eo):>8.4f} | "
                  f"{len(theirs):>8}/{views:<3}{np.nanmean(ec):>8.4f}{rms(ec):>8.4f}{np.nanmax(ec):>8.4f} | {np.nanmean(bo):.4f} / {np.nanmean(bc):.4f}"
                  f" | {np.nanmean(es):>8.4f}{np.nanmax(es):>8.4f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--views", type=int, default=8)
    args = ap.parse_args()
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect-cli"], cwd=ROOT)
    photos_section()
    synthetic_section(args.views)
    synthetic_section(args.views, tilt=1.0, zrange=(0.8, 1.3))


if __name__ == "__main__":
    main()
