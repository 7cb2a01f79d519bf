"""What a run archive records about the software that computed it, so the run can be
understood and repeated months later: versions and the source revision (content hashes:
:mod:`nlupdate.fingerprints`)."""
from __future__ import annotations

import importlib.metadata
import platform
import subprocess
import sys
from pathlib import Path

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


def environment() -> dict[str, object]:
    """Python, platform, package versions and source revision."""
    return {"python": sys.version.split()[0], "platform": platform.platform(), "packages": package_versions(),
            "source": source_revision()}


