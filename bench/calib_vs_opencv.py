#!/usr/bin/env python3
"""Camera calibration, aerorect beside OpenCV on the very same corner points.

Input: data/calib/left_corners.csv (OpenCV's corners of its own left01..14 photos in
data/calib-opencv: 13 views x 54 points, object points X, Y, Z in metres, pixels u, v), in the
file's view order for both tools.

1. The solve alone, interleaved round by round in one run: cv2.calibrateCamera (the call only;
   no corner detection) and aerorect's `calib_solve` example (aerorect_solve::calib::calibrate,
   timed inside the process; one solve per line sent to it), same model:
     opencv            <-> flags 0 (k1, k2, p1, p2, k3)
     opencv-thin-prism <-> CALIB_THIN_PRISM_MODEL
   aerorect stops when an update moves every point by less than 1e-6 px (at most 200
   iterations); OpenCV runs its default criteria but with 200 iterations, aerorect's cap, instead
   of 30 (COUNT + EPS, 200, DBL_EPSILON): with 30 its thin-prism fit stops short (RMS 0.40787,
   cx 3.4 px from its own converged 370.135). Medians, the ratio OpenCV / aerorect, and both
   tools' RMS reprojection error, intrinsics and coefficients.
   With --before EXE (the same example built from an earlier commit, e.g. the numeric-Jacobian
   one), that build is timed in the same rounds too.
2. The whole command, interleaved: `aerorect calibrate --points ... --image-size 640x480`
   (process start, CSV, solve, report) and a Python process that imports cv2, reads the CSV and
   calls calibrateCamera.

Creates its own venv (bench/.venv) with opencv-python-headless and numpy. Builds the example
and the CLI (cargo build --release) first.
usage: python3 bench/calib_vs_opencv.py [--rounds N] [--threads T] [--before EXE]
"""
import argparse, csv, os, re, statistics, subprocess, sys, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402

CORNERS = os.path.join(ROOT, "data", "calib", "left_corners.csv")
EXAMPLE = os.path.join(ROOT, "target", "release", "examples", "calib_solve")
CLI = os.path.join(ROOT, "target", "release", "aerorect")
MODELS = [("opencv", 0), ("opencv-thin-prism", cv2.CALIB_THIN_PRISM_MODEL)]
CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, sys.float_info.epsilon)
NAMES = ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4"]


def views():
    """Object and image points per view, in the file's order."""
    out = {}
    for r in csv.DictReader(open(CORNERS)):
        out.setdefault(r["image"], []).append([float(r[k]) for k in "XYZuv"])
    obj = [np.ascontiguousarray(np.array(v, np.float32)[:, :3]) for v in out.values()]
    img = [np.ascontiguousarray(np.array(v, np.float32)[:, 3:]) for v in out.values()]
    return obj, img


def parse_ours(line):
    t = line.split()
    return {t[i]: float(t[i + 1]) for i in range(0, len(t) - 1, 2)}


def start(exe, model):
    return subprocess.Popen([exe, CORNERS, "640x480", model, "1e-6"], stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, text=True, bufsize=1)


def ask(p):
    p.stdin.write("\n")
    p.stdin.flush()
    return parse_ours(p.stdout.readline())


def solve_section(rounds, before):
    obj, img = views()
    print(f"1. The solve alone ({sum(len(o) for o in obj)} points in {len(obj)} views; cv2 {cv2.__version__}, "
          f"{cv2.getNumThreads()} threads; {rounds} interleaved rounds; medians)")
    print(f"{'model':<19}{'OpenCV ms':>10}{'ours ms':>9}{'OpenCV/ours':>12}{'RMS OpenCV':>12}{'RMS ours':>10}{'iters ours':>11}"
          + (f"{'before ms':>10}{'before/ours':>12}" if before else ""))
    details = []
    for model, flags in MODELS:
        p = start(EXAMPLE, model)
        q = start(before, model) if before else None
        t_cv, t_ours, t_before = [], [], []
        for i in range(rounds):
            sides = [0, 1, 2] if q else [0, 1]
            for side in (sides if i % 2 == 0 else sides[::-1]):
                if side == 0:
                    t = time.perf_counter()
                    cv = cv2.calibrateCamera(obj, img, (640, 480), None, None, flags=flags, criteria=CRITERIA)
                    t_cv.append((time.perf_counter() - t) * 1e3)
                elif side == 1:
                    ours = ask(p)
                    t_ours.append(ours["ms"])
                else:
                    t_before.append(ask(q)["ms"])
        for proc in (p, q):
            if proc:
                proc.stdin.close()
                proc.wait()
        rms, K, D = cv[0], cv[1], cv[2].ravel()
        m_cv, m_ours = statistics.median(t_cv), statistics.median(t_ours)
        extra = ""
        if q:
            m_before = statistics.median(t_before)
            extra = f"{m_before:>10.2f}{m_before / m_ours:>12.2f}"
        print(f"{model:<19}{m_cv:>10.2f}{m_ours:>9.2f}{m_cv / m_ours:>12.2f}{rms:>12.5f}{ours['rms']:>10.5f}{int(ours['iterations']):>11}{extra}")
        details.append((model, K, D, ours))
    for model, K, D, ours in details:
        print(f"  {model}: parameter   OpenCV        aerorect      difference")
        cvv = {"fx": K[0, 0], "fy": K[1, 1], "cx": K[0, 2], "cy": K[1, 2], **dict(zip(NAMES, D))}
        for name in ["fx", "fy", "cx", "cy"] + NAMES:
            if name in ours:
                print(f"    {name:<6}{cvv[name]:>16.6f}{ours[name]:>14.6f}{ours[name] - cvv[name]:>+14.2e}")


OPENCV_SCRIPT = """
import csv, sys, numpy as np, cv2
out = {}
for r in csv.DictReader(open(sys.argv[1])):
    out.setdefault(r["image"], []).append([float(r[k]) for k in "XYZuv"])
obj = [np.ascontiguousarray(np.array(v, np.float32)[:, :3]) for v in out.values()]
img = [np.ascontiguousarray(np.array(v, np.float32)[:, 3:]) for v in out.values()]
crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, sys.float_info.epsilon)
rms, K, D, _, _ = cv2.calibrateCamera(obj, img, (640, 480), None, None, criteria=crit)
print(rms, K[0, 0], K[1, 1], K[0, 2], K[1, 2])
"""


def command_section(rounds):
    print(f"2. The whole command (process start to exit; {rounds} interleaved rounds; medians), model opencv")
    ours_cmd = [CLI, "calibrate", "--points", CORNERS, "--image-size", "640x480", "--model", "opencv", "--stop-px", "1e-6"]
    cv_cmd = [sys.executable, "-c", OPENCV_SCRIPT, CORNERS]
    t_ours, t_cv = [], []
    for i in range(rounds):
        for side in ((0, 1) if i % 2 == 0 else (1, 0)):
            cmd, ts = (cv_cmd, t_cv) if side == 0 else (ours_cmd, t_ours)
            t = time.perf_counter()
            text = subprocess.run(cmd, capture_output=True, text=True, check=True).stdout
            ts.append((time.perf_counter() - t) * 1e3)
            if side == 1:
                rms = float(re.search(r"^RMS (\S+)", text, re.M).group(1))
    m_ours, m_cv = statistics.median(t_ours), statistics.median(t_cv)
    print(f"  aerorect calibrate --points: {m_ours:.1f} ms (RMS {rms:.5f})")
    print(f"  python + cv2 import + CSV + calibrateCamera: {m_cv:.1f} ms; ratio {m_cv / m_ours:.2f}")


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--rounds", type=int, default=30)
    ap.add_argument("--threads", type=int, default=2, help="cv2.setNumThreads (aerorect's solve is single-threaded)")
    ap.add_argument("--before", help="an earlier build of the calib_solve example, timed in the same rounds")
    args = ap.parse_args()
    cv2.setNumThreads(args.threads)
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect-solve", "--example", "calib_solve"], cwd=ROOT)
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect-cli"], cwd=ROOT)
    solve_section(args.rounds, args.before)
    command_section(max(5, args.rounds // 3))


if __name__ == "__main__":
    main()
