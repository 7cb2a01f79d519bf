"""Rendered archive figures kept between runs: :class:`FigureStore`.

Drawing the archive's PNG figures is most of what writing an archive costs (4–5 s for the
demo's eight, 1.7 s of them the prediction panels); a rerun whose every step came from the
cache would draw the same pictures again. A figure is a function of the results it shows,
the study file (titles, names) and the plotting code, so it is kept under
:func:`nlupdate.orchestration.tasks.keys.figures_key` — the study, every step's cache key, the reporting
code and matplotlib's version — and any change of one draws it afresh.

A kept figure is data like a task record: signed with the user's cache secret
(:func:`nlupdate.orchestration.tasks.signing.sign`) under its key and name, and written atomically. One
that fails its check is named in one line and drawn again; one that cannot be written is
simply not kept.
"""
from __future__ import annotations

import warnings
from pathlib import Path

from nlupdate.files import write_bytes_atomic
from nlupdate.notices import NlupdateWarning
from nlupdate.orchestration.tasks.signing import sign, signed_payload

FOLDER = "figures-v1"


class FigureStore:
    """PNG figures of one set of results (``key``) in ``<cache>/figures-v1``; ``refresh``:
    never read a kept figure (draw every one, and keep the new ones)."""

    def __init__(self, cache_folder: str | Path, key: str, refresh: bool = False) -> None:
        self.folder, self.key, self.refresh = Path(cache_folder) / FOLDER, key, refresh

    def _path(self, name: str) -> Path:
        return self.folder / f"{self.key}-{name}"

    def get(self, name: str) -> bytes | None:
        """The kept PNG ``name`` of these results, or None."""
        if self.refresh:
            return None
        path = self._path(name)
        try:
            content = path.read_bytes()
        except OSError:
            return None
        try:
            return signed_payload(path.name, content)
        except ValueError as error:
            warnings.warn(f"kept figure {path}: {error}; not used, the figure is drawn again", NlupdateWarning,
                          stacklevel=2)
            return None

    def put(self, name: str, png: bytes) -> None:
        """Keep the PNG ``name`` of these results (silently not, when the folder cannot be written)."""
        path = self._path(name)
        try:
            self.folder.mkdir(parents=True, exist_ok=True)
            write_bytes_atomic(path, sign(path.name, png))
        except OSError:
            pass
