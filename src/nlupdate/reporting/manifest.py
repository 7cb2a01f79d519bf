"""What a run archive records about the software that computed it, so the run can be
understood and repeated months later: versions and the source revision (content hashes:
:mod:`nlupdate.fingerprints`)."""
from __future__ import annotations

import importlib.metadata
import platform
import subprocess
import sys
from pathlib import Path

import nlupdate
from nlupdate.fingerprints import source_hash

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
    root = Path(__file__).resolve().parents[3]
    try:
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "HEAD"], capture_output=True, text=True, timeout=10)
        if commit.returncode != 0:
            return None
        status = subprocess.run(["git", "-C", str(root), "status", "--porcelain", "--", "src"], capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return {"commit": commit.stdout.strip(), "local_changes": bool(status.stdout.strip())}


def code_hash() -> str:
    """SHA-256 of the nlupdate package's Python sources as this process runs them: what a git
    commit cannot name when the tree had local changes, or when nlupdate is not a git checkout
    (its version, 0.1.0, names no code)."""
    return source_hash([Path(nlupdate.__file__).parent])


def environment() -> dict[str, object]:
    """Python, platform, package versions, source revision and the hash of the code that ran."""
    return {"python": sys.version.split()[0], "platform": platform.platform(), "packages": package_versions(),
            "source": source_revision(), "code_sha256": code_hash()}


