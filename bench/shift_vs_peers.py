#!/usr/bin/env python3
"""aerorect's shift estimators against scikit-image and OpenCV on the very same noisy frames.

`aerorect motion-sim --dump-dir` writes every noisy pair (f32 TIFF) and a manifest with the
true shift and our estimates and times; this script runs
  - skimage.registration.phase_cross_correlation(ref, cur, upsample_factor=100)
  - cv2.phaseCorrelate(ref, cur, window=Hann)
on the same files, and prints per scene and SNR the error RMS and median time of each method.
Each peer's sign convention is calibrated first on a whole-pixel shift (no assumption).
OpenCV runs on one thread (`opencv`) and on its default threads (`opencv-mt`). Ours run in
motion-sim's default pool: xcorr, phase and the linear JTC use one core whatever the pool, the
binarised JTC (`jtc`) splits over two threads when it has them; `jtc-1t` times it again in a
one-thread pool (`--threads 1`) on the same pairs.

Timing is interleaved in one run: --rounds times (default 3) our motion-sim (which times each of
our estimators on each pair) and then the peers on the same pairs; the medians are over all
rounds, so load from other processes falls on both sides alike.

Creates its own venv (bench/.venv) with opencv-python-headless, scikit-image, numpy.
usage: python3 bench/shift_vs_peers.py [--trials N] [--rounds N] [--snr-db LIST] [--fourier] [--data ../shared/data/aerial]
"""
import argparse, csv, os, subprocess, sys, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402




ensure_venv(["opencv-python-headless", "numpy", "scikit-image"], ["cv2", "numpy", "skimage"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402
import skimage  # noqa: E402
from skimage.registration import phase_cross_correlation  # noqa: E402

SCENES = {"airport": "sipi_5.3.02.tiff", "coast": "sipi_2.1.05.tiff", "roads": "sipi_2.2.17.tiff", "urban": "sipi_5.2.09.tiff"}


OURS = ["jtc", "jtc-linear", "xcorr", "phase"]
CV_THREADS = cv2.getNumThreads()


def on_threads(n, fn):
    def run(r, c):
        cv2.setNumThreads(n)
        return fn(r, c)
    return run


def peers(n):
    hann = cv2.createHanningWindow((n, n), cv2.CV_32F)
    cv = lambda r, c: cv2.phaseCorrelate(r, c, hann)[0]
    return {
        "skimage": lambda r, c: tuple(phase_cross_correlation(r, c, upsample_factor=100)[0][::-1]),
        "opencv": on_threads(1, cv),
        "opencv-mt": on_threads(CV_THREADS, cv),
    }


def calibrate(fn, n):
    """Sign of each axis such that +d means 'a feature at x in ref is at x + d in cur'."""
    rng = np.random.default_rng(0)
    base = rng.random((n + 20, n + 20)).astype(np.float32)  # white noise: every method locks on
    ref = base[10:10 + n, 10:10 + n].copy()
    cur = base[10 - 2:10 - 2 + n, 10 - 3:10 - 3 + n].copy()  # content moved by (+3, +2)
    ex, ey = fn(ref, cur)
    return (np.sign(ex) * 1.0 if abs(abs(ex) - 3) < 0.2 else 0.0, np.sign(ey) * 1.0 if abs(abs(ey) - 2) < 0.2 else 0.0)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--trials", type=int, default=20)
    ap.add_argument("--rounds", type=int, default=3, help="interleaved timing rounds (ours, then the peers)")
    ap.add_argument("--snr-db", default="-2,4,10,20")
    ap.add_argument("--size", type=int, default=256)
    ap.add_argument("--fourier", action="store_true", help="band-limited (Fourier) shifts instead of linear interpolation")
    ap.add_argument("--data", default=os.path.join(ROOT, "..", "shared", "data", "aerial"))
    args = ap.parse_args()
    out = os.path.join(HERE, "out", "shift_pairs")
    if os.path.isdir(out):
        for f in os.listdir(out):
            os.remove(os.path.join(out, f))
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect-cli"], cwd=ROOT)
    exe = os.path.join(ROOT, "target", "release", "aerorect")
    linked = []
    for name, f in SCENES.items():
        link = os.path.join(HERE, "out", name + ".tiff")
        if not os.path.exists(link):
            os.symlink(os.path.abspath(os.path.join(args.data, f)), link)
        linked.append(link)
    fns = peers(args.size)
    signs = {k: calibrate(f, args.size) for k, f in fns.items()}
    if any(0.0 in s for s in signs.values()):
        sys.exit(f"a peer failed the whole-pixel calibration: {signs}")
    errs, times, frames = {}, {}, {}
    for round_ in range(args.rounds):
        for f in os.listdir(out) if os.path.isdir(out) else []:
            os.remove(os.path.join(out, f))
        subprocess.check_call([exe, "motion-sim", *linked, "--trials", str(args.trials), f"--snr-db={args.snr_db}",
                               "--size", str(args.size), "--method", ",".join(OURS), "--dump-dir", out,
                               "--plot", os.path.join(HERE, "out", "shift_vs_peers.svg")] + (["--fourier"] if args.fourier else []),
                              stdout=subprocess.DEVNULL)
        with open(os.path.join(out, "manifest.csv")) as fh:
            rows = list(csv.DictReader(fh))
        one = out + "_1t"
        os.makedirs(one, exist_ok=True)
        subprocess.check_call([exe, "--threads", "1", "motion-sim", *linked, "--trials", str(args.trials), f"--snr-db={args.snr_db}",
                               "--size", str(args.size), "--method", "jtc", "--dump-dir", one,
                               "--plot", os.path.join(HERE, "out", "shift_vs_peers_1t.svg")]
                              + (["--fourier"] if args.fourier else []), stdout=subprocess.DEVNULL)
        with open(os.path.join(one, "manifest.csv")) as fh:
            seconds_1t = {(r["scene"], r["snr_db"], r["trial"]): float(r["jtc_seconds"]) for r in csv.DictReader(fh)}
        for row in rows:
            key = (row["scene"], float(row["snr_db"]))
            stem = f"{row['scene']}_{row['snr_db']}_{row['trial']}"
            if stem not in frames:
                frames[stem] = (cv2.imread(os.path.join(out, stem + "_ref.tif"), cv2.IMREAD_UNCHANGED),
                                cv2.imread(os.path.join(out, stem + "_cur.tif"), cv2.IMREAD_UNCHANGED))
            ref, cur = frames[stem]
            dx, dy = float(row["dx"]), float(row["dy"])
            for m in OURS:
                if round_ == 0:
                    errs.setdefault(key, {}).setdefault(m, []).append((float(row[f"{m}_dx"]) - dx) ** 2 + (float(row[f"{m}_dy"]) - dy) ** 2)
                times.setdefault(key, {}).setdefault(m, []).append(float(row[f"{m}_seconds"]))
            times[key].setdefault("jtc-1t", []).append(seconds_1t[(row["scene"], row["snr_db"], row["trial"])])
            for name, fn in fns.items():
                t = time.perf_counter()
                ex, ey = fn(ref, cur)
                secs = time.perf_counter() - t
                sx, sy = signs[name]
                if round_ == 0:
                    errs[key].setdefault(name, []).append((sx * ex - dx) ** 2 + (sy * ey - dy) ** 2)
                times[key].setdefault(name, []).append(secs)
    methods = OURS + list(fns)
    print(f"skimage {skimage.__version__}, cv2 {cv2.__version__} (opencv: 1 thread, opencv-mt: {CV_THREADS}); {args.size} x {args.size} frames, {args.trials} trials per cell, shifts by {'Fourier shift' if args.fourier else 'linear interpolation'}; times: medians over {args.rounds} interleaved rounds")
    print("error RMS in px (median ms per pair)")
    print(f"{'scene':<9}{'SNR':>5}" + "".join(f"{m:>18}" for m in methods))
    all_t = {m: [] for m in methods}
    all_e = {m: [] for m in methods}
    for key in sorted(errs):
        scene, snr = key
        line = f"{scene:<9}{snr:>5.0f}"
        for m in methods:
            e = np.array(errs[key][m])
            all_e[m] += list(e)
            all_t[m] += times[key][m]
            line += f"{np.sqrt(e.mean()):>10.4f} ({np.median(times[key][m]) * 1e3:4.2f})"
        print(line)
    all_t["jtc-1t"] = [t for key in times for t in times[key]["jtc-1t"]]
    med = {m: np.median(v) for m, v in all_t.items()}
    print("all cells: error RMS px / median ms per pair")
    for m in methods:
        print(f"  {m:<10} {np.sqrt(np.mean(all_e[m])):8.4f} px  {med[m] * 1e3:6.3f} ms")
    print(f"  {'jtc-1t':<10} {'(as jtc)':>11}  {med['jtc-1t'] * 1e3:6.3f} ms")
    print("time ratios (peer / ours, > 1: ours faster): "
          + ", ".join(f"{p} / {o} = {med[p] / med[o]:.2f}" for p in ("opencv", "opencv-mt") for o in ("xcorr", "phase"))
          + f", skimage / xcorr = {med['skimage'] / med['xcorr']:.1f}")
    print("error RMS per SNR (all scenes): " + "; ".join(
        f"{snr:g} dB: " + ", ".join(f"{m} {np.sqrt(np.mean([e for k in errs if k[1] == snr for e in errs[k][m]])):.4f}" for m in ("jtc", "jtc-linear", "xcorr", "phase", "opencv"))
        for snr in sorted({k[1] for k in errs})))


if __name__ == "__main__":
    main()
