"""Feature tie points side by side with OpenCV's SIFT on real frame pairs.

For each pair (the senseFly snowpeak pairs along and across strips, one of them turned half a
turn, and two DJI frames), both sides reduce the frames by the same integer factor (box means:
ours gray_reduced, OpenCV INTER_AREA on the cropped frame), detect and describe SIFT with
the same settings (4000 features, contrastThreshold 0.02), match with
Lowe's ratio 0.8 and a mutual check, and verify by RANSAC at 1 px of the reduced frame:
ours ransac_homography / ransac_fundamental, OpenCV findHomography / findFundamentalMat.
Prints verified inliers per pair and seconds per frame (reduction + SIFT, decoding excluded),
one thread each side, and the ratios.

OpenCV's SIFT always upsamples the frame 2x before its first octave (firstOctave = -1;
`enable_precise_upscale` only picks how), and our flight pipeline does not (FeatureOptions::
double_first_octave, off: about a third of the time for about half the keypoints). So ours
runs twice: as the pipeline does ("ours"), and upsampled like OpenCV ("ours 2x"), the same
algorithm on the same settings.

    python3 bench/features_vs_opencv.py [--long-side 1152,768,1536]
"""
import argparse, json, os, subprocess, sys, time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402

DATA = os.environ.get("AERORECT_SHARED_DATA", os.path.join(ROOT, "..", "shared", "data"))
SNOW = os.path.join(DATA, "flights", "snowpeak", "img")
PAIRS = [
    ("2188/2189 along", f"{SNOW}/IMG_2188.JPG", f"{SNOW}/IMG_2189.JPG"),
    ("2212/2213 across", f"{SNOW}/IMG_2212.JPG", f"{SNOW}/IMG_2213.JPG"),
    ("2280/2281 along", f"{SNOW}/IMG_2280.JPG", f"{SNOW}/IMG_2281.JPG"),
    ("2281/2282 along", f"{SNOW}/IMG_2281.JPG", f"{SNOW}/IMG_2282.JPG"),
    ("2188/2189 turned 180", f"{SNOW}/IMG_2188.JPG", f"rot180:{SNOW}/IMG_2189.JPG"),
    ("DJI 0030/0031", f"{DATA}/drone-xmp/DJI_0030.JPG", f"{DATA}/drone-xmp/DJI_0031.JPG"),
]


def opencv_frame(arg, long_side):
    rot = arg.startswith("rot180:")
    img = cv2.imread(arg[len("rot180:"):] if rot else arg, cv2.IMREAD_GRAYSCALE)
    if rot:
        img = img[::-1, ::-1].copy()
    start = time.perf_counter()
    h, w = img.shape
    f = max(1, -(-max(w, h) // long_side))
    small = img[: h // f * f, : w // f * f]
    if f > 1:
        small = cv2.resize(small, (w // f, h // f), interpolation=cv2.INTER_AREA)
    sift = cv2.SIFT_create(nfeatures=4000, contrastThreshold=0.02, enable_precise_upscale=False)
    kp, des = sift.detectAndCompute(small, None)
    return kp, des, time.perf_counter() - start


def opencv_pair(a, b, long_side):
    ka, da, ta = opencv_frame(a, long_side)
    kb, db, tb = opencv_frame(b, long_side)
    bf = cv2.BFMatcher(cv2.NORM_L2)
    fwd = bf.knnMatch(da, db, k=2)
    back = {m.queryIdx: m.trainIdx for m in bf.match(db, da)}
    good = [m for m, n in (p for p in fwd if len(p) == 2)
            if m.distance < 0.8 * n.distance and back.get(m.trainIdx) == m.queryIdx]
    pa = np.float64([ka[m.queryIdx].pt for m in good])
    pb = np.float64([kb[m.trainIdx].pt for m in good])
    ih = iF = 0
    if len(good) >= 8:
        _, mh = cv2.findHomography(pa, pb, cv2.RANSAC, 1.0, maxIters=4000, confidence=0.999)
        _, mf = cv2.findFundamentalMat(pa, pb, cv2.FM_RANSAC, 1.0, 0.999, 4000)
        ih = int(mh.sum()) if mh is not None else 0
        iF = int(mf.sum()) if mf is not None else 0
    return dict(keypoints=[len(ka), len(kb)], seconds=[ta, tb], matches=len(good), inliers_h=ih, inliers_f=iF)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--long-side", default="1152", help="comma-separated long sides in px")
    args = ap.parse_args()
    if not os.path.isdir(SNOW):
        sys.exit(f"{SNOW} is absent")
    subprocess.check_call(["cargo", "build", "-q", "--release", "-p", "aerorect", "--example", "feature_ties"], cwd=ROOT)
    exe = os.path.join(ROOT, "target", "release", "examples", "feature_ties")
    cv2.setNumThreads(1)
    env = dict(os.environ, RAYON_NUM_THREADS="1")
    print(f"cv2 {cv2.__version__}; one thread each; RANSAC 1 px of the reduced frame; s/frame = reduction + SIFT")
    head = (f"{'pair':<22}{'long':>5}{'keypoints ours/2x/cv':>22}{'F inliers ours/2x/cv':>22}"
            f"{'s/frame ours/2x/cv':>21}{'t ratio ours/cv, 2x/cv':>24}")
    print(head)
    rows = []
    for long_side in [int(s) for s in args.long_side.split(",")]:
        for name, a, b in PAIRS:
            ours, ours2 = (json.loads(subprocess.check_output([exe, *flag, str(long_side), a, b], env=env)
                                      .decode().splitlines()[0]) for flag in ([], ["--double-first-octave"]))
            cv = opencv_pair(a, b, long_side)
            t = [sum(r["seconds"]) / 2 for r in (ours, ours2, cv)]
            kp = "/".join(str(r["keypoints"][0]) for r in (ours, ours2, cv))
            fi = "/".join(str(r["inliers_f"]) for r in (ours, ours2, cv))
            ts = "/".join(f"{v:.3f}" for v in t)
            print(f"{name:<22}{long_side:>5}{kp:>22}{fi:>22}{ts:>21}{t[0] / t[2]:>12.2f}{t[1] / t[2]:>12.2f}")
            rows.append(dict(pair=name, long_side=long_side, ours=ours, ours_doubled=ours2, opencv=cv))
    out = os.path.join(HERE, "out")
    os.makedirs(out, exist_ok=True)
    with open(os.path.join(out, "features_vs_opencv.json"), "w") as f:
        json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
