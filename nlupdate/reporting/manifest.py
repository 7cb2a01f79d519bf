"""What a run archive records so the run can be understood and repeated months later:
content hashes of its inputs, the versions of everything that computed it, the seeds."""
from __future__ import annotations

import hashlib
import os
import importlib.metadata
import platform
import subprocess
import sys
from pathlib import Path

import pandas as pd

from nlupdate.input_files import pinned_bytes

PACKAGES = ("nlupdate", "numpy", "scipy", "pandas", "pyarrow", "matplotlib", "pyuff", "prefect", "prefect-dask", "dask",
            "distributed")


def package_versions() -> dict[str, str]:
    """Installed versions of the packages that compute or orchestrate a run."""
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def source_revision() -> dict[str, object] | None:
    """Git commit of the nlupdate source tree (and whether it had local changes), or None
    when nlupdate is not installed from a git checkout."""
    root = Path(__file__).resolve().parents[2]
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
        if commit.returncode != 0:
            return None
        status = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--", "nlupdate", "adapters", "flows",
                                 "tasks"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return {"commit": commit.stdout.strip(), "local_changes": bool(status.stdout.strip())}


def environment() -> dict[str, object]:
    """Python, platform, package versions and source revision."""
    return {"python": sys.version.split()[0], "platform": platform.platform(), "packages": package_versions(),
            "source": source_revision()}


def table_hash(table: pd.DataFrame) -> str:
    """SHA-256 of a table's content (values, column names and order; index ignored)."""
    digest = hashlib.sha256(",".join(map(str, table.columns)).encode())
    digest.update(pd.util.hash_pandas_object(table, index=False).to_numpy().tobytes())
    return digest.hexdigest()


def file_hash(path: str | Path) -> str:
    """SHA-256 of a file's bytes (of its snapshot, when a run has pinned it:
    :func:`nlupdate.input_files.pinned`)."""
    taken = pinned_bytes(path)
    if taken is not None:
        return hashlib.sha256(taken).hexdigest()
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def tree_hash(folder: str | Path) -> str:
    """SHA-256 over a folder's files: their relative paths and contents, in sorted order.
    A link is hashed by its content when it points to a file inside the folder, else by
    the text of the link (its target is not read)."""
    digest = hashlib.sha256()
    root = Path(folder)
    inner = root.resolve()
    for path in sorted(p for p in root.rglob("*") if p.is_file() or p.is_symlink()):
        digest.update(path.relative_to(root).as_posix().encode())
        pointee = path.resolve()
        if path.is_symlink() and not (pointee.is_file() and inner in pointee.parents):
            digest.update(b"link:" + os.fsencode(os.readlink(path)))
        else:
            digest.update(file_hash(path).encode())
    return digest.hexdigest()
