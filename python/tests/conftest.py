"""Shared fixtures: synthetic DJI photos (the bundled data/aero1.jpg with an XMP packet, as the
CLI's own tests make them) and the `aerorect` binary the Python results are compared with."""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
AERO1 = ROOT / "data" / "aero1.jpg"


def xmp(lat: float = 53.9, lon: float = 27.55, *, yaw=0.0, pitch=-90.0, roll=0.0, rel=80.0, abs_=310.0,
        focal_px=500.0) -> str:
    return (
        '<x:xmpmeta xmlns:x="adobe:ns:meta/"><rdf:RDF '
        'xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#"><rdf:Description '
        'rdf:about="DJI Meta Data" xmlns:drone-dji="http://www.dji.com/drone-dji/1.0/" '
        f'drone-dji:GpsLatitude="{lat:+.7f}" drone-dji:GpsLongtitude="{lon:+.7f}" '
        f'drone-dji:AbsoluteAltitude="{abs_:+.2f}" drone-dji:RelativeAltitude="{rel:+.2f}" '
        f'drone-dji:GimbalRollDegree="{roll:+.2f}" drone-dji:GimbalYawDegree="{yaw:+.2f}" '
        f'drone-dji:GimbalPitchDegree="{pitch:+.2f}" '
        f'drone-dji:CalibratedFocalLength="{focal_px}"/></rdf:RDF></x:xmpmeta>'
    )


def jpeg_with_xmp(path: Path, packet: str | None, source: Path = AERO1) -> Path:
    """data/aero1.jpg (or `source`) with an APP1 XMP packet inserted after SOI."""
    jpeg = source.read_bytes()
    out = bytearray(jpeg[:2])
    if packet is not None:
        payload = b"http://ns.adobe.com/xap/1.0/\0" + packet.encode()
        out += b"\xff\xe1" + (len(payload) + 2).to_bytes(2, "big") + payload
    out += jpeg[2:]
    path.write_bytes(bytes(out))
    return path


def photo(dir_: Path, name: str, lat=53.9, lon=27.55, **kw) -> Path:
    return jpeg_with_xmp(dir_ / name, xmp(lat, lon, **kw))


def flight_photos(dir_: Path, n: int, *, cols: int = 10, step_deg=0.0002) -> list[Path]:
    """`n` nadir frames on a grid, rows `step_deg` of latitude apart (about 22 m at 80 m with
    a 500 px focal length: the 640 x 480 frames overlap)."""
    out = []
    for k in range(n):
        r, c = divmod(k, cols)
        out.append(photo(dir_, f"DJI_{k:04d}.JPG", lat=53.9 + r * step_deg,
                         lon=27.55 + c * step_deg * 1.7, yaw=(7 * k) % 20 - 10,
                         pitch=-90 + (k % 5)))
    return out


def crop_photo(dir_: Path, name: str, col0: int, width: int, **kw) -> Path:
    """Columns col0..col0 + width of data/aero1.jpg as a JPEG (GDAL's encoder) with DJI tags:
    two crops, placed apart on the ground as far as their columns are, overlap truly."""
    import rasterio

    with rasterio.open(AERO1) as src:
        a = src.read()[:, :, col0:col0 + width]
    tmp = dir_ / (name + ".crop.jpg")
    with rasterio.open(tmp, "w", driver="JPEG", width=width, height=a.shape[1], count=3,
                       dtype="uint8", QUALITY=95) as dst:
        dst.write(a)
    out = jpeg_with_xmp(dir_ / name, xmp(**kw), source=tmp)
    tmp.unlink()
    for side in dir_.glob(name + ".crop.jpg*"):
        side.unlink()
    return out


@pytest.fixture(scope="session")
def cli() -> str:
    """The `aerorect` binary: $AERORECT_BIN, else target/release/aerorect. scripts/test-all.sh
    builds it and sets AERORECT_BIN, so there a missing binary fails; alone, pytest skips the
    comparisons with the CLI, saying so."""
    env = os.environ.get("AERORECT_BIN")
    path = env or str(ROOT / "target" / "release" / "aerorect")
    if not (os.path.isfile(path) and os.access(path, os.X_OK)):
        if env:
            pytest.fail(f"AERORECT_BIN={env} is not an executable")
        pytest.skip(f"SKIP: no aerorect binary at {path} (cargo build --release)")
    return path


def run(cli: str, *args, ok: bool | None = True) -> subprocess.CompletedProcess:
    """Runs the CLI; `ok`: it must succeed (True), fail (False), or either (None)."""
    p = subprocess.run([cli, *map(str, args)], capture_output=True, text=True)
    if ok is True:
        assert p.returncode == 0, p.stderr
    elif ok is False:
        assert p.returncode != 0, p.stdout
    return p


def cli_error(p: subprocess.CompletedProcess) -> str:
    """The CLI's error message (its `error: ` line)."""
    lines = [l for l in p.stderr.splitlines() if l.startswith("error: ")]
    assert lines, p.stderr
    return lines[-1][len("error: "):]


__all__ = ["photo", "flight_photos", "run", "cli_error", "jpeg_with_xmp", "ROOT", "shutil"]
