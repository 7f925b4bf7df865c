#!/usr/bin/env python3
"""Camera files written by `aerorect camera convert`, read by the peers that define the formats,
and the peers' files read by aerorect:

- OpenCV (cv2.FileStorage) reads our FileStorage YAML and XML: camera_matrix and
  distortion_coefficients equal our camera (12 coefficients: rational + thin prism);
  a FileStorage YAML written by OpenCV is read by aerorect to the same values;
- Orthority (its param_io readers + create_camera) reads our interior YAML (opencv type) and
  our OpenSfM cameras.json (brown): its intrinsic matrix K and distortion vector equal ours.
Prints the largest relative difference of each check. Uses bench/.venv (opencv-python-headless,
numpy, orthority).
usage: python3 bench/camera_formats_vs_peers.py
"""
import os, subprocess, sys, tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["opencv-python-headless", "numpy", "orthority"], ["cv2", "numpy", "orthority"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402
from orthority import param_io  # noqa: E402
from orthority.camera import create_camera  # noqa: E402

BIN = os.path.join(ROOT, "target", "release", "aerorect")
W, H = 4000, 3000
K = dict(fx=3678.9, fy=3671.5, cx=2010.25, cy=1482.75)
TWELVE = [-0.2653, 0.0467, 1.83e-3, -3.15e-4, 0.2523, 0.013, -0.021, 4.5e-3, 2e-4, -1e-4, 3e-4, -5e-5]
NAMES = ["k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4"]


def toml(coefs, model):
    s = f"fx_px = {K['fx']}\nfy_px = {K['fy']}\ncx_px = {K['cx']}\ncy_px = {K['cy']}\n"
    s += f"image_size_px = [{W}, {H}]\n\n[distortion]\nmodel = \"{model}\"\n"
    return s + "".join(f"{n} = {v!r}\n" for n, v in zip(NAMES, coefs) if v != 0.0)


def convert(src, dst, *extra):
    subprocess.run([BIN, "camera", "convert", src, dst, *extra], check=True, capture_output=True)


def rel(a, b):
    a, b = np.asarray(a, float).ravel(), np.asarray(b, float).ravel()
    return float(np.max(np.abs(a - b) / np.maximum(np.maximum(np.abs(a), np.abs(b)), 1e-300)))


def main():
    if not os.path.exists(BIN):
        subprocess.check_call(["cargo", "build", "--release", "-p", "aerorect-cli"], cwd=ROOT)
    want_k = np.array([[K["fx"], 0, K["cx"]], [0, K["fy"], K["cy"]], [0, 0, 1.0]])
    with tempfile.TemporaryDirectory() as d:
        p = lambda n: os.path.join(d, n)  # noqa: E731
        open(p("cam.toml"), "w").write(toml(TWELVE, "opencv-rational-thin-prism"))
        five = TWELVE[:5] + [0.0] * 7
        open(p("brown.toml"), "w").write(toml(five, "opencv"))
        for out, extra in [("cam.yml", []), ("cam.xml", ["--to", "opencv-xml"]), ("int.yaml", [])]:
            convert(p("cam.toml"), p(out), *extra)
        convert(p("brown.toml"), p("cameras.json"))
        for name in ["cam.yml", "cam.xml"]:
            fs = cv2.FileStorage(p(name), cv2.FILE_STORAGE_READ)
            km, dist = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
            size = (int(fs.getNode("image_width").real()), int(fs.getNode("image_height").real()))
            assert size == (W, H), size
            print(f"OpenCV reads our {name}: K rel diff {rel(km, want_k):.1e}, "
                  f"dist rel diff {rel(dist, TWELVE):.1e} ({dist.size} coefficients)")
        # OpenCV writes, aerorect reads.
        fs = cv2.FileStorage(p("cv.yml"), cv2.FILE_STORAGE_WRITE)
        fs.write("image_width", W)
        fs.write("image_height", H)
        fs.write("camera_matrix", want_k)
        fs.write("distortion_coefficients", np.array(TWELVE).reshape(-1, 1))
        fs.release()
        convert(p("cv.yml"), p("back.toml"))
        back = dict(l.split(" = ") for l in open(p("back.toml")) if " = " in l and "model" not in l)
        got = [float(back[k]) for k in ["fx_px", "fy_px", "cx_px", "cy_px"]] + [float(back.get(n, 0)) for n in NAMES]
        print(f"aerorect reads OpenCV's own FileStorage YAML: rel diff {rel(got, list(K.values()) + TWELVE):.1e}")
        for name, reader, coefs in [("int.yaml", param_io.read_oty_int_param, TWELVE),
                                    ("cameras.json", param_io.read_osfm_int_param, five)]:
            params = next(iter(reader(p(name)).values()))
            cam = create_camera(**params)
            n = len(cam._dist_param)
            print(f"Orthority reads our {name} ({params['cam_type'].value}): K rel diff "
                  f"{rel(cam._K, want_k):.1e}, dist rel diff {rel(cam._dist_param, coefs[:n]):.1e}")


if __name__ == "__main__":
    main()
