"""The run archives under a results root: find them, name one, read its key results, and
load the study it ran from the archive alone.

A run is ``<root>/<study>/<run id>/`` (:mod:`nlupdate.reporting.archive`). Its status:

* ``complete``   the archive is whole and no updating run failed;
* ``failed``     the archive is whole but some updating runs failed (named in it);
* ``incomplete`` a temporary folder a run left when it was killed while writing (its
  writer no longer runs, or runs on another host; the next run removes it);
* ``writing``    a temporary folder whose writer still runs on this host;
* ``damaged``    a folder under its final name whose manifest or tables cannot be read,
  or whose manifest points outside the archive (listed with the reason; never read
  further, so one bad archive hides no other).

Only a folder under its final name holds a manifest that :func:`find_runs` reads as
whole: archives are written in a temporary sibling and renamed when complete.
"""
from __future__ import annotations

import datetime as dt
import json
import os
import re
import stat
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import pandas as pd

from nlupdate.core.updating.runs import best_ranked
from nlupdate.files import HOST, inside, name_problem, temporary_writer, writer_alive
from nlupdate.reporting.archive import MANIFEST
from nlupdate.fingerprints import file_hash, tree_hash

STATUSES = ("complete", "failed", "incomplete", "writing", "damaged")
# a run id: ``<UTC time>-<8 hex digits>``, ``-<n>`` added when that folder existed already
_RUN_ID = re.compile(r"(\d{8}T\d{6}Z)-([0-9a-f]{8})(?:-(\d+))?")


class ArchiveError(ValueError):
    """A run archive cannot be found or read; the message says which and why."""


@dataclass(frozen=True)
class ArchivedRun:
    """One run folder (``run_id`` is its folder name) and what its manifest says."""

    folder: Path
    study: str
    run_id: str
    status: str
    manifest: dict[str, Any] = field(default_factory=dict, repr=False)
    reason: str = ""

    @property
    def started(self) -> str:
        return self.manifest.get("run", {}).get("started_utc", "")

    def table(self, name: str) -> pd.DataFrame | None:
        """``tables/<name>.parquet`` of the archive, or None when the run has none;
        :class:`ArchiveError` naming the file when it cannot be read."""
        path = self.folder / "tables" / f"{name}.parquet"
        if not path.is_file():
            return None
        try:
            return pd.read_parquet(path)
        except Exception as error:  # pyarrow's errors for a corrupt file
            raise ArchiveError(f"{path}: cannot be read ({type(error).__name__}: {error})") from None


def read_manifest(folder: Path) -> dict[str, Any]:
    """The manifest of the archive ``folder``, checked (:func:`check_manifest`)."""
    path = Path(folder) / MANIFEST
    try:
        manifest = json.loads(path.read_text())
    except FileNotFoundError:
        raise ArchiveError(f"{folder} is not a run archive (no {MANIFEST})") from None
    except (OSError, ValueError) as error:
        raise ArchiveError(f"{path}: cannot read the manifest ({error})") from None
    except RecursionError:  # json's decoder recurses once per level of nesting
        raise ArchiveError(f"{path}: cannot read the manifest (nested too deep: not a manifest nlupdate "
                           f"wrote)") from None
    check_manifest(folder, manifest)
    return manifest


def check_manifest(folder: Path, manifest: Any) -> None:
    """:class:`ArchiveError` unless ``manifest`` has the shape nlupdate writes and every
    path in it stays inside ``folder``: the study name is one folder name, every archived
    input a relative path that resolves inside the archive."""
    where = Path(folder) / MANIFEST
    if not isinstance(manifest, dict):
        raise ArchiveError(f"{where}: holds a {type(manifest).__name__}, not a manifest object")
    if not isinstance(manifest.get("run_id"), str) or not isinstance(manifest.get("run"), dict):
        raise ArchiveError(f"{where}: no run record (run_id, run): not a manifest nlupdate wrote")
    study = manifest.get("study", {})
    name = study.get("name") if isinstance(study, dict) else None
    if not isinstance(study, dict) or (name is not None and name_problem(name) is not None):
        raise ArchiveError(f"{where}: study name {name!r} is not one folder name ({name_problem(name)}); "
                           f"the manifest points outside the archive")
    inputs = manifest.get("inputs", {})
    files = inputs.get("files", []) if isinstance(inputs, dict) else None
    if not isinstance(files, list):
        raise ArchiveError(f"{where}: inputs.files is not a list")
    for entry in files:
        if not isinstance(entry, dict) or not all(isinstance(entry.get(k), str)
                                                  for k in ("as_written", "archived", "sha256")):
            raise ArchiveError(f"{where}: an inputs.files entry lacks as_written, archived or sha256")
        archived = Path(entry["archived"])
        if archived.is_absolute() or ".." in archived.parts:
            raise ArchiveError(f"{where}: archived input {entry['archived']!r} points outside the archive")
        try:
            inside(folder, Path(folder) / archived)
        except ValueError:
            raise ArchiveError(f"{where}: archived input {entry['archived']!r} points outside the archive "
                               f"(through a link)") from None


def _temporary_status(folder: Path) -> str:
    writer = temporary_writer(folder.name)
    if writer is None:
        return "incomplete"
    host, pid = writer
    return "writing" if host == HOST and writer_alive(pid) else "incomplete"


def open_run(folder: str | os.PathLike) -> ArchivedRun:
    """The run archive in ``folder`` (a whole one: it has a manifest)."""
    folder = Path(folder)
    manifest = read_manifest(folder)
    status = manifest.get("status") or ("failed" if manifest.get("failures") else "complete")
    study = manifest.get("study", {}).get("name") or folder.parent.name
    if status not in STATUSES:
        raise ArchiveError(f"{folder / MANIFEST}: unknown status {status!r}")
    return ArchivedRun(folder, study, folder.name, status, manifest)


def find_runs(root: str | os.PathLike = "results", study: str | None = None) -> list[ArchivedRun]:
    """Every run under ``root`` (optionally of one study), oldest first (:func:`_run_order`);
    temporary folders of killed or running writers are listed as ``incomplete`` / ``writing``."""
    root = Path(root)
    if not root.is_dir():
        raise ArchiveError(f"no results folder {root}")
    runs = []
    for study_folder in sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith(".")):
        for folder in sorted(p for p in study_folder.iterdir() if p.is_dir()):
            if folder.name.startswith(".tmp-"):
                runs.append(ArchivedRun(folder, study_folder.name, folder.name, _temporary_status(folder)))
            elif (folder / MANIFEST).is_file():
                try:
                    runs.append(open_run(folder))
                except ArchiveError as error:
                    runs.append(ArchivedRun(folder, study_folder.name, folder.name, "damaged", reason=str(error)))
    if study is not None:
        runs = [r for r in runs if r.study == study or r.folder.parent.name == study]
    return sorted(runs, key=_run_order)


def _run_order(run: ArchivedRun) -> tuple:
    """Oldest first to the second (the run id's resolution); runs of one second by id, an
    original before its ``-1``, ``-2``, … ``-10`` (which may have started a moment earlier
    but was written later)."""
    named = _RUN_ID.fullmatch(run.run_id)
    second = named.group(1) if named else run.run_id.removeprefix(".tmp-")
    if run.started:
        try:
            second = f"{dt.datetime.fromisoformat(run.started).astimezone(dt.timezone.utc):%Y%m%dT%H%M%SZ}"
        except ValueError:
            second = run.started
    if named:
        return second, named.group(2), int(named.group(3) or 0), run.started, run.run_id
    return second, run.run_id, 0, run.started, run.run_id


def resolve_run(spec: str, root: str | os.PathLike = "results") -> ArchivedRun:
    """A run named by its folder, its whole id, or an unambiguous prefix of its id under ``root``."""
    path = Path(spec)
    if path.is_dir():
        return open_run(path)
    matches = [r for r in find_runs(root) if r.run_id.startswith(spec) and r.status not in ("incomplete", "writing")]
    exact = [r for r in matches if r.run_id == spec]
    if exact:  # a whole id names its run, though ``<id>-1`` starts with it too
        matches = exact
    if not matches:
        raise ArchiveError(f"no run folder {spec!r} and no run id under {root} starts with {spec!r} "
                           f"(see `nlupdate archive list --root {root}`)")
    if len(matches) > 1:
        names = ", ".join(f"{r.study}/{r.run_id}" for r in matches[:6])
        raise ArchiveError(f"{spec!r} names {len(matches)} runs under {root} ({names}{', …' if len(matches) > 6 else ''}); "
                           f"give more of the id")
    if matches[0].status == "damaged":
        raise ArchiveError(matches[0].reason)
    return matches[0]


def best_candidate(run: ArchivedRun) -> str | None:
    """The updating run the study ranked best (its archived ranking,
    :func:`~nlupdate.core.updating.runs.best_ranked`); None when the study did not update."""
    return best_ranked(run.table("ranking"))


def key_results(run: ArchivedRun) -> dict[str, Any]:
    """Identified parameters, the best candidate and its updated parameters (value, std),
    and the lowest FRAC of the best candidate's prediction over the force levels (None when
    it was not predicted)."""
    out: dict[str, Any] = {"identified": {}, "best": best_candidate(run), "updated": {}, "min_frac": None}
    identified = run.table("identification")
    if identified is not None:
        out["identified"] = {row.parameter: [float(row.value), float(row.std)] for row in identified.itertuples()}
    runs = run.table("runs")
    if runs is not None and out["best"] is not None:
        row = runs[runs["candidate"] == out["best"]]
        if len(row):
            row = row.iloc[0]
            for column in runs.columns:
                if column.startswith("p:") and pd.notna(row[column]):
                    name = column[2:]
                    std = row.get(f"std:{name}")
                    out["updated"][name] = [float(row[column]), None if std is None or pd.isna(std) else float(std)]
    correlation = run.table("correlation")
    if correlation is not None:
        updated = correlation[correlation["model"] == out["best"]]
        if len(updated):
            out["min_frac"] = float(updated["frac"].min())
    return out


def archived_inputs(run: ArchivedRun) -> tuple[dict[str, Path], list[str]]:
    """(path as written in the study → its copy in the archive, notes about copies that
    changed since the run). A copy whose content no longer matches its recorded hash is
    still used; the note says so, so a rerun can explain a difference."""
    redirect, notes = {}, []
    check_manifest(run.folder, run.manifest)
    for entry in run.manifest.get("inputs", {}).get("files", []):
        copy = run.folder / entry["archived"]
        if not copy.exists():
            raise ArchiveError(f"{run.folder}: the archived input {entry['archived']} ({entry['as_written']!r} in the study) "
                               f"is missing")
        digest = tree_hash(copy) if copy.is_dir() else file_hash(copy)
        if digest != entry["sha256"]:
            notes.append(f"input {entry['as_written']!r} ({entry['archived']}) was edited after the run: sha256 "
                         f"{entry['sha256'][:12]} → {digest[:12]}")
        redirect[entry["as_written"]] = copy
    return redirect, notes


def archived_study_text(folder: Path) -> str | None:
    """The text of the archive ``folder``'s study.toml (None when it has none); an
    :class:`ArchiveError` when it is a link or no regular file: nlupdate writes a file
    there, and a link put in its place would make a rerun or a comparison read whatever
    it points to."""
    path = Path(folder) / "study.toml"
    if path.is_symlink():
        raise ArchiveError(f"{path}: is a link (to {os.readlink(path)}), not the study file the run wrote; not followed")
    if not path.exists():
        return None
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0))
        with os.fdopen(descriptor, "rb") as stream:
            if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
                raise ArchiveError(f"{path}: is not a regular file, not the study file the run wrote")
            return stream.read().decode("utf-8")
    except (OSError, UnicodeDecodeError) as error:
        raise ArchiveError(f"{path}: cannot be read ({error})") from None


def archived_study(run: ArchivedRun):
    """The study of ``run`` as it ran, reading the input copies kept in the archive; and
    the notes of :func:`archived_inputs`."""
    from nlupdate.study import study_from_text

    text_path = run.folder / "study.toml"
    text = archived_study_text(run.folder)
    if text is None:
        raise ArchiveError(f"{run.folder}: no study.toml: this archive cannot be rerun")
    redirect, notes = archived_inputs(run)
    study = study_from_text(text, text_path, redirect, redirect_only=True)
    return replace(study, name=run.manifest.get("study", {}).get("name", study.name)), notes
