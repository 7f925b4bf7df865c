"""Where the distributed runs read and write: local paths or fsspec URLs, a task's local copies
and scratch folder, and the moves that land staged outputs."""

from __future__ import annotations

import os
import shutil
import tempfile
from typing import List, Optional

# Options that name files a worker must be able to read.
_FILE_OPTIONS = ("dem", "camera", "poses")


def _is_url(p: str) -> bool:
    return "://" in p and not p.startswith("file://")


def _join(base: str, name: str) -> str:
    return base.rstrip("/") + "/" + name if _is_url(base) else os.path.join(base, name)


def _stem(p: str) -> str:
    name = p.rstrip("/").rsplit("/", 1)[-1]
    name = os.path.basename(name)
    dot = name.rfind(".")
    return name[:dot] if dot > 0 else name


def _with_extension(name: str, ext: str) -> str:
    """Rust's Path::with_extension on a file name (batch names its outputs so)."""
    dot = name.rfind(".")
    return (name[:dot] if dot > 0 else name) + "." + ext

def _sidecars(path: str) -> List[str]:
    """An output and its sidecars (PNG: world file, .prj, .aux.xml)."""
    if path.lower().endswith(".png"):
        base = path[: -len(".png")]
        return [path, base + ".pgw", base + ".prj", path + ".aux.xml"]
    return [path]


class _Local:
    """Local copies of URL inputs and a scratch folder for URL outputs (one per task)."""

    def __init__(self) -> None:
        self.dir: Optional[str] = None

    def scratch(self) -> str:
        if self.dir is None:
            self.dir = tempfile.mkdtemp(prefix="aerorect-")
        return self.dir

    def input(self, p: str) -> str:
        if not _is_url(p):
            return p
        import fsspec

        local = os.path.join(self.scratch(), "in", os.path.basename(p.rstrip("/")))
        os.makedirs(os.path.dirname(local), exist_ok=True)
        fs, path = fsspec.core.url_to_fs(p)
        fs.get(path, local)
        prj = path.rsplit(".", 1)[0] + ".prj"
        if fs.exists(prj):  # a pose table's CRS
            fs.get(prj, local.rsplit(".", 1)[0] + ".prj")
        return local

    def output(self, p: str) -> str:
        if not _is_url(p):
            return p
        return os.path.join(self.scratch(), "out", os.path.basename(p.rstrip("/")))

    def upload(self, local: str, url: str) -> None:
        if not _is_url(url):
            return
        import fsspec

        fs, path = fsspec.core.url_to_fs(url)
        for lf, rf in zip(_sidecars(local), _sidecars(path)):
            if os.path.exists(lf):
                fs.put(lf, rf)

    def close(self) -> None:
        if self.dir is not None:
            shutil.rmtree(self.dir, ignore_errors=True)


def _local_options(opts: dict, local: _Local) -> dict:
    return {k: (local.input(v) if k in _FILE_OPTIONS else v) for k, v in opts.items()}


def _exists(p: str) -> bool:
    if _is_url(p):
        import fsspec

        fs, path = fsspec.core.url_to_fs(p)
        return fs.exists(path)
    return os.path.exists(p)


def _put_text(path: str, text: str) -> None:
    if _is_url(path):
        import fsspec

        fs, p = fsspec.core.url_to_fs(path)
        fs.pipe(p, text.encode())
    else:
        with open(path, "w", encoding="utf-8") as f:
            f.write(text)


def _move(src: str, dst: str) -> bool:
    if _is_url(src):
        import fsspec

        fs, s = fsspec.core.url_to_fs(src)
        if not fs.exists(s):
            return False
        fs.mv(s, fsspec.core.url_to_fs(dst)[1])
        return True
    if not os.path.exists(src):
        return False
    os.replace(src, dst)
    return True


def _remove_tree(path: str) -> None:
    if _is_url(path):
        import fsspec

        fs, p = fsspec.core.url_to_fs(path)
        if fs.exists(p):
            fs.rm(p, recursive=True)
    else:
        shutil.rmtree(path, ignore_errors=True)
