"""Cache keys: what a cached result depends on, as one fingerprint.

A key is :func:`nlupdate.fingerprints.fingerprint` of everything the result depends on:

* the code that computes it — the modules it runs, found by following the imports from
  where it starts (:func:`imported_modules`; nothing kept by hand): :func:`numerics_code`
  for the chain's steps and jobs (not the reporting, plots, CLI, flows or tasks: editing a
  plot or the report keeps every cached identification and updating run), :func:`fe_code`
  for FE points, so editing a report does not throw away hours of FE runs,
  :func:`discovery_code` for candidate fits;
* for the archive's figures (:mod:`nlupdate.orchestration.tasks.figures`) :func:`reporting_code` and
  matplotlib's version, the whole study file and every step's key;
* the inputs: the study sections the step's entry in :data:`nlupdate.study.chain.CHAIN`
  names, the content of every input file of the study (as the run read it), the keys of
  the step's inputs; for a job, the job itself and the FE model's identity; for an FE
  point, the adapter's point key (model fingerprint and parameter values).

The code hashes are computed once per process, when first needed. Finding a module's
imports parses it (0.44 s of CPU for the 171 modules of :func:`numerics_code`, in every
run); the import sets are kept in the user's nlupdate folder (``code-imports.json``,
:func:`nlupdate.user_config.config_dir`: private to the user, since they decide what a key
covers) under each source's SHA-256, so a run parses only sources changed since.
"""
from __future__ import annotations

import ast
import contextlib
import functools
import hashlib
import json
import os
import re
from pathlib import Path
from typing import Any, Iterator, Sequence

import nlupdate
from nlupdate.fe.adapters.registry import AdapterSpec
from nlupdate.fingerprints import fingerprint, path_hash, source_hash
from nlupdate.study.chain import Step
from nlupdate.study.spec import Study

#: Where the code of each kind of cached result starts: the result depends on these
#: modules and on every nlupdate module they import, directly or inside a function
#: (:func:`imported_modules`) — derived, so no list of packages can fall behind the code.
STUDY_ROOTS = ("nlupdate.study.chain", "nlupdate.study.steps")
DISCOVERY_ROOTS = ("nlupdate.core.discovery",)
FE_ROOTS = ("nlupdate.fe.adapters.registry",)


_PACKAGE = Path(nlupdate.__file__).parent


def _module_file(name: str, package: Path) -> Path | None:
    """The source of module ``name`` (``nlupdate.…``) under ``package``, or None."""
    parts = name.split(".")[1:]
    folder = package.joinpath(*parts)
    for path in (folder / "__init__.py", folder.with_suffix(".py")):
        if path.is_file():
            return path
    return None


def _imports(path: Path, package: Path) -> frozenset[str]:
    stat = path.stat()
    return _parsed_imports(path, package, stat.st_mtime_ns, stat.st_size)


class _ImportSets:
    """The import statements' modules of sources parsed before, by the SHA-256 of the
    source, read from and written back to ``code-imports.json`` in the user's nlupdate folder."""

    def __init__(self) -> None:
        self.known: dict[str, list[str]] | None = None
        self.added = False

    def _path(self) -> Path | None:
        from nlupdate.user_config import UserConfigError, config_dir

        try:
            return config_dir() / "code-imports.json"
        except UserConfigError:  # no folder of the user's: parse every time
            return None

    def get(self, digest: str) -> frozenset[str] | None:
        if self.known is None:
            path, self.known = self._path(), {}
            with contextlib.suppress(OSError, ValueError):
                read = json.loads(path.read_text()) if path else {}
                self.known = {key: value for key, value in read.items() if isinstance(value, list)}
        found = self.known.get(digest)
        return None if found is None else frozenset(found)

    def put(self, digest: str, names: frozenset[str]) -> None:
        self.known[digest] = sorted(names)
        self.added = True

    def save(self) -> None:
        """Write the sets back when a source was parsed (atomic; a failure costs a parse next time)."""
        path = self._path() if self.added else None
        if path is None:
            return
        temporary = path.with_name(f"{path.name}.{os.getpid()}")
        with contextlib.suppress(OSError):
            temporary.write_text(json.dumps(self.known))
            os.replace(temporary, path)
        self.added = False


_IMPORT_SETS = _ImportSets()


def _statements(nodes: list) -> Iterator[ast.AST]:
    """Every statement of ``nodes`` and of the blocks inside them (function and class
    bodies, branches, handlers, match cases): where import statements can be — a walk of
    statements only, not of every expression (a fifth of the nodes, and most of the time)."""
    for node in nodes:
        yield node
        for field in ("body", "orelse", "finalbody", "handlers", "cases"):
            inner = getattr(node, field, None)
            if isinstance(inner, list):
                yield from _statements(inner)


@functools.cache
def _parsed_imports(path: Path, package: Path, mtime_ns: int, size: int) -> frozenset[str]:
    """The nlupdate modules a source imports: its import statements (function bodies
    included, ``TYPE_CHECKING`` blocks not; kept by the source's SHA-256) and — when it
    imports by name at run time (``importlib.import_module``) — every module of its folder
    (listed now: a module added beside it counts)."""
    text = path.read_text()
    found = _IMPORT_SETS.get(hashlib.sha256(text.encode()).hexdigest())
    if found is None:
        found = _import_statements(text)
        _IMPORT_SETS.put(hashlib.sha256(text.encode()).hexdigest(), found)
    if re.search(r"\.import_module\(", text):  # a module imported by name: any module of the folder
        folder = path.parent.relative_to(package.parent)
        found = found | {".".join([*folder.parts, sibling.stem]) for sibling in path.parent.glob("*.py")
                         if sibling.stem != "__main__"}
    return found


def _import_statements(text: str) -> frozenset[str]:
    """The nlupdate modules the import statements of source ``text`` name (parsed)."""
    found: set[str] = set()
    statements = list(_statements(ast.parse(text).body))
    skipped = {id(node) for block in statements if isinstance(block, ast.If)
               and isinstance(block.test, ast.Name) and block.test.id == "TYPE_CHECKING" for node in block.body}
    for node in statements:
        if id(node) in skipped:
            continue
        if isinstance(node, ast.Import):
            found.update(alias.name for alias in node.names if alias.name.startswith("nlupdate"))
        elif isinstance(node, ast.ImportFrom) and node.module and node.module.startswith("nlupdate"):
            found.update(f"{node.module}.{alias.name}" for alias in node.names)
            found.add(node.module)
    return frozenset(found)


def imported_modules(roots: Sequence[str], package: Path) -> list[Path]:
    """The sources of ``roots`` and of every nlupdate module they import, transitively,
    with the packages whose ``__init__`` an import runs (sorted)."""
    seen: dict[str, Path] = {}
    waiting = list(roots)
    while waiting:
        name = waiting.pop()
        parts = name.split(".")
        for depth in range(1, len(parts) + 1):  # importing a.b.c runs a and a.b first
            module = ".".join(parts[:depth])
            path = _module_file(module, package)
            if module in seen or path is None:
                continue
            seen[module] = path
            waiting.extend(_imports(path, package))
    _IMPORT_SETS.save()
    return sorted(seen.values())


def _code_hash(roots: Sequence[str]) -> str:
    digest = hashlib.sha256()
    for path in imported_modules(roots, _PACKAGE):
        digest.update(str(path.relative_to(_PACKAGE)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


@functools.cache
def numerics_code() -> str:
    """Hash of the code the study's steps run (:data:`STUDY_ROOTS` and all they import)."""
    return _code_hash(STUDY_ROOTS)


@functools.cache
def discovery_code() -> str:
    """Hash of the code a discovery candidate fit depends on (:data:`DISCOVERY_ROOTS`, …)."""
    return _code_hash(DISCOVERY_ROOTS)


@functools.cache
def fe_code() -> str:
    """Hash of the code an FE evaluation depends on (the adapters' registry and all it imports)."""
    return _code_hash(FE_ROOTS)


@functools.cache
def reporting_code() -> str:
    """Hash of the code that draws and writes an archive (:mod:`nlupdate.reporting`)."""
    return source_hash([_PACKAGE / "reporting"])


def figures_key(study: Study, step_keys: dict[str, str]) -> str:
    """The archive figures of one run's results: the study file, every step's key (step
    name → key), the reporting code and matplotlib's version."""
    from importlib.metadata import version

    return fingerprint("figures", reporting_code(), version("matplotlib"), study.sha256, input_files(study),
                       sorted(step_keys.items()))


def input_files(study: Study) -> dict[str, str]:
    """Content hashes of the files the study reads (as written → SHA-256), as a run
    pinned them (:func:`nlupdate.study.spec.inputs_read_once`)."""
    return {written: path_hash(path) for written, path in sorted(study.input_files.items())}


def sections(study: Study, step: Step) -> list[Any]:
    """The study sections a step depends on."""
    return [getattr(study, name) for name in step.sections]


def step_key(step: Step, study: Study, input_keys: Sequence[str | None]) -> str:
    """A chain step's result: the step, the code, its study sections, the study's input
    files and the keys of its inputs."""
    return fingerprint("step", step.name, numerics_code(), sections(study, step), input_files(study),
                       list(input_keys))


def job_key(step: Step, study: Study, job: Any, model_identity: str, input_keys: Sequence[str | None]) -> str:
    """One job of a fan-out step (an updating run, a prediction): the job and its FE
    model, and — unless the job describes itself (:attr:`~nlupdate.study.chain.Step.jobs_describe_themselves`)
    — what its step's key is made of."""
    if step.jobs_describe_themselves:
        return fingerprint("job", step.name, numerics_code(), job, model_identity)
    return fingerprint("job", step.name, numerics_code(), job, model_identity, sections(study, step),
                       input_files(study), list(input_keys))


def gathered_key(step: Step, job_keys: Sequence[str]) -> str:
    """The key of a fan-out step's gathered result: its jobs' keys."""
    return fingerprint("gathered", step.name, list(job_keys))


def model_identity(spec: AdapterSpec, model_fingerprint: str) -> str:
    """An FE model: its description and its built adapter's fingerprint (a deck's content, …)."""
    return fingerprint("adapter", spec.identity(), model_fingerprint)


def point_key(spec: AdapterSpec, point_of_adapter: str) -> str:
    """One FE evaluation: the adapter's own point key (model fingerprint and values) and
    the FE code."""
    return fingerprint("point", fe_code(), spec.identity(), point_of_adapter)


def candidate_key(job: Any) -> str:
    """One discovery candidate fit: the job's content (data, model, place and effect) and
    the discovery code."""
    return fingerprint("candidate", discovery_code(), job)
