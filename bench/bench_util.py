"""Small pieces the bench scripts share. Imported after `peer_env.ensure_venv`, so numpy and
rasterio are imported where used: a script needs only the packages of what it calls."""
import re
import time


def median_time(fn, repeats):
    """(median seconds of `repeats` calls of fn, the last call's result)."""
    import numpy as np

    ts, out = [], None
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        ts.append(time.perf_counter() - t)
    return float(np.median(ts)), out


def xmp_float(path, name):
    """A DJI XMP field (drone-dji:NAME, attribute or element form) of a JPEG; None if absent."""
    with open(path, "rb") as f:
        head = f.read(1 << 20).decode("latin-1")
    m = re.search(r'drone-dji:%s="([^"]+)"' % name, head) or re.search(
        r"<drone-dji:%s>([^<]+)<" % name, head)
    return float(m.group(1)) if m else None


def write_flat_dem(path, crs, bounds, z, res=1.0, **creation):
    """A constant DEM over bounds (e0, n0, e1, n1), pixel corners at multiples of res;
    `creation` goes to the GeoTIFF driver (e.g. compress="deflate")."""
    import numpy as np
    import rasterio
    from rasterio.transform import Affine

    e0, n0 = np.floor(bounds[0] / res) * res, np.floor(bounds[1] / res) * res
    e1, n1 = np.ceil(bounds[2] / res) * res, np.ceil(bounds[3] / res) * res
    w, h = int(round((e1 - e0) / res)), int(round((n1 - n0) / res))
    with rasterio.open(path, "w", driver="GTiff", width=w, height=h, count=1, dtype="float32",
                       crs=crs, transform=Affine(res, 0, e0, 0, -res, n1), **creation) as ds:
        ds.write(np.full((1, h, w), z, np.float32))
