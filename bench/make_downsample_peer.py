#!/usr/bin/env python3
"""Stored peer results for aerorect-raster's tests/downsample.rs: OpenCV's cv2.resize INTER_AREA.

Writes data/downsample/: the input `aero1_gray_240x180.u8` (data/aero1.jpg read as gray by
OpenCV, its top-left 240 x 180 pixels from (200, 150), raw row-major bytes) and, for each factor
f in 4, 3, 2.5, `area_x{f}_{W}x{H}.u8`: cv2.resize(input, (240/f, 180/f), INTER_AREA).

usage: python3 bench/make_downsample_peer.py
"""
import os, sys

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)
from peer_env import ensure_venv  # noqa: E402

ensure_venv(["opencv-python-headless", "numpy"], ["cv2", "numpy"])
import cv2  # noqa: E402
import numpy as np  # noqa: E402

OUT = os.path.join(ROOT, "data", "downsample")
os.makedirs(OUT, exist_ok=True)
gray = cv2.imread(os.path.join(ROOT, "data", "aero1.jpg"), cv2.IMREAD_GRAYSCALE)
src = np.ascontiguousarray(gray[150:330, 200:440])
assert src.shape == (180, 240)
src.tofile(os.path.join(OUT, "aero1_gray_240x180.u8"))
for f in (4, 3, 2.5):
    w, h = int(240 / f), int(180 / f)
    out = cv2.resize(src, (w, h), interpolation=cv2.INTER_AREA)
    name = f"area_x{f}_{w}x{h}.u8"
    out.tofile(os.path.join(OUT, name))
    print(name, out.shape, "cv2", cv2.__version__)
