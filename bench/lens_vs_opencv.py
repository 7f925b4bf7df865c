#!/usr/bin/env python3
"""Calibration and undistortion, aerorect beside OpenCV on the same inputs.

- cv2.calibrateCamera on data/calib/left_corners.csv (13 views x 54 points, 5 coefficients)
  against aerorect's calibration of the same points (the `lens_timing` example, compute only);
- cv2.initUndistortRectifyMap + cv2.remap (bilinear) of a 4000 x 3000 gray frame against
  aerorect's undistortion plan + warp with the same camera (medians, ratios printed).
Creates its own venv (bench/.venv) with opencv-python-headless and numpy.
usage: python3 bench/lens_vs_opencv.py [--repeats N]
"""
import argparse, json, os, subprocess, sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402
from bench_util import median_time  # noqa: E402




ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402



def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--repeats", type=int, default=10)
    args = ap.parse_args()
    rows = np.genfromtxt(os.path.join(ROOT, "data", "calib", "left_corners.csv"), delimiter=",", names=True, dtype=None, encoding=None)
    images = sorted(set(rows["image"]))
    obj = [np.array([[r["X"], r["Y"], r["Z"]] for r in rows if r["image"] == im], np.float32) for im in images]
    img = [np.array([[r["u"], r["v"]] for r in rows if r["image"] == im], np.float32) for im in images]
    cv2.setNumThreads(2)
    t_cal, res = median_time(lambda: cv2.calibrateCamera(obj, img, (640, 480), None, None), args.repeats)
    rms, K, dist = res[0], res[1], res[2].ravel()
    print(f"cv2 {cv2.__version__}: calibrateCamera median {t_cal * 1e3:.1f} ms, RMS {rms:.5f}, fx {K[0, 0]:.4f} fy {K[1, 1]:.4f} cx {K[0, 2]:.4f} cy {K[1, 2]:.4f}")
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect", "--example", "lens_timing"], cwd=ROOT)
    exe = os.path.join(ROOT, "target", "release", "examples", "lens_timing")
    ours = json.loads(subprocess.check_output([exe, os.path.join(ROOT, "data", "calib", "left_corners.csv"), str(args.repeats)]))
    print(f"aerorect calibrate (compute only) median {ours['calibrate_s'] * 1e3:.1f} ms")
    print(f"calibration: aerorect is {t_cal / ours['calibrate_s']:.2f}x as fast as OpenCV")
    # Undistortion of a 4000 x 3000 frame with the camera of the criterion bench.
    k = np.array([[3000.0, 0, 1999.5], [0, 3000.0, 1499.5], [0, 0, 1]])
    d = np.array([-0.265, -0.0467, 0.0018, -0.0003, 0.252])
    frame = (np.random.default_rng(1).random((3000, 4000)) * 255).astype(np.uint8)

    def cv_undistort():
        m1, m2 = cv2.initUndistortRectifyMap(k, d, None, k, (4000, 3000), cv2.CV_16SC2)
        return cv2.remap(frame, m1, m2, cv2.INTER_LINEAR)

    def cv_undistort_f32():
        m1, m2 = cv2.initUndistortRectifyMap(k, d, None, k, (4000, 3000), cv2.CV_32FC1)
        return cv2.remap(frame, m1, m2, cv2.INTER_LINEAR)

    t_u, _ = median_time(cv_undistort, args.repeats)
    t_uf, _ = median_time(cv_undistort_f32, args.repeats)
    print(f"OpenCV initUndistortRectifyMap + remap, 4000 x 3000 gray8 bilinear, 2 threads: {t_u * 1e3:.1f} ms (16-bit fixed-point map), {t_uf * 1e3:.1f} ms (f32 map)")
    print(f"aerorect undistort (plan + warp, exact f64 coordinates, 2 threads): {ours['undistort_s'] * 1e3:.1f} ms")
    print(f"undistortion: aerorect is {t_u / ours['undistort_s']:.2f}x as fast as OpenCV's fixed-point map, {t_uf / ours['undistort_s']:.2f}x its f32 map")


if __name__ == "__main__":
    main()
