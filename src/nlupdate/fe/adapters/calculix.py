"""CalculiX (``ccx``) behind the :class:`~nlupdate.fe.adapters.base.FEAdapter` interface.

Length: the deck contract, the ``.dat`` parser and the adapter are one contract with
CalculiX and change together; the docstring below is a third of it.

Contract with the deck generator
--------------------------------
A deck generator is a callable ``parameters -> (model_text, coordinates)``:

* ``model_text`` — CalculiX *model data* in consistent SI units (m, kg, s, Pa): nodes,
  elements, materials (with ``*DENSITY``), sections, ``*BOUNDARY`` and the node sets
  named in ``coordinates``. It must not contain ``*STEP``: the adapter appends the
  analysis step itself::

      *STEP
      *FREQUENCY
      <n_modes>
      *NODE PRINT,NSET=<set>,GLOBAL=YES      (one per node set used by a coordinate)
      U
      *END STEP

* ``coordinates`` — ``{coordinate name: (node set name, direction)}``, direction one of
  ``"ux" | "uy" | "uz"`` (global axes), e.g. ``{"tip:uz": ("TIP", "uz")}``. When a set
  holds several nodes the coordinate is the **mean** of that displacement component over
  the set (meant for a few nodes placed symmetrically about the measurement point).

A generator that has a ``fingerprint()`` method (see
:class:`nlupdate.fe.adapters.calculix_tbeam.TBeamDeck`) fingerprints the model itself;
otherwise pass ``model_id`` — a string that changes whenever the generator changes.

Output parsing (``job.dat``)
----------------------------
``E I G E N V A L U E   O U T P U T`` block: columns mode, eigenvalue (rad/s)², real
part (rad/s), real part (cycles/s = Hz), imaginary part (rad/s); the Hz column is used.
Per mode, ``E I G E N V A L U E    N U M B E R  i`` is followed by one
``displacements (vx,vy,vz) for set <SET> and time …`` table per ``*NODE PRINT`` request
(rows: node, ux, uy, uz). ccx prints values with 7 significant digits, so use relative
finite-difference steps of 1e-4 or larger for sensitivities.

CalculiX normalises eigenvectors to unit modal mass (UᵀMU = 1, it logs
"normalizing the eigenmode"), so the shapes are mass-normalised in 1/√kg as
:class:`~nlupdate.fe.adapters.base.ModalResult` requires (checked in the tests against the
Euler–Bernoulli cantilever, whose mass-normalised tip value is 2/√(ρAL)).

Failure detection: ccx often exits with code 0 after an error, so besides the exit
code (a crash, e.g. a segmentation fault, is a non-zero code or a signal) and the time
limit the log is scanned for ``*ERROR``, and the ``.dat`` must exist and hold the
eigenvalue block with exactly the requested number of modes, finite eigenvalues, finite
non-negative frequencies in ascending order (within :data:`FREQUENCY_ORDER_RTOL`, ccx
prints 7 digits) and one finite displacement table per requested set and mode. A
clearly negative eigenvalue (a mechanism, hourglassing or missing supports) is also an
error. Every such failure names the run directory and the log (and quotes its end).
"""
from __future__ import annotations

import dataclasses
import re
import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np

from nlupdate.fingerprints import fingerprint
from nlupdate.fe.adapters.base import AdapterError, FEAdapter, ModalResult, check_frequencies
from nlupdate.fe.adapters.runner import (
    ExecutableNotFoundError,
    ProcessRunner,
    RunResult,
    RunTimeoutError,
    log_lines,
    run_failure,
    write_text_atomic,
)

CCX_INSTALL_HINT = (
    "Install CalculiX with `apt-get install calculix-ccx` (Debian/Ubuntu) or set the adapter's "
    "`executable` to the path of your ccx binary."
)

DIRECTIONS = {"ux": 0, "uy": 1, "uz": 2}
JOB_NAME = "job"

Coordinates = Mapping[str, tuple[str, str]]
DeckGenerator = Callable[[Mapping[str, float]], tuple[str, Coordinates]]

# Nodes per element for the CalculiX element types whose connectivity may span lines.
_NODES_PER_ELEMENT = {
    "C3D20": 20, "C3D20R": 20, "C3D15": 15, "C3D10": 10, "C3D8": 8, "C3D8R": 8, "C3D8I": 8,
    "C3D6": 6, "C3D4": 4, "S8": 8, "S8R": 8, "S6": 6, "S4": 4, "S4R": 4, "S3": 3,
    "CPS8": 8, "CPS8R": 8, "CPE8": 8, "CPE8R": 8, "CAX8": 8, "CAX8R": 8, "CPS4": 4, "CPE4": 4,
    "B32": 3, "B32R": 3, "B31": 2, "B31R": 2, "T3D2": 2, "T3D3": 3,
    "MASS": 1, "SPRING1": 1, "SPRING2": 2, "SPRINGA": 2, "DASHPOTA": 2,
}
_NOT_MESH = {"MASS", "SPRING1", "SPRING2", "SPRINGA", "DASHPOTA"}

# a Fortran real, or the NaN/Infinity a broken solve prints (read, then refused by the checks)
_FLOAT = r"(?:[-+]?(?:\d+\.?\d*|\.\d+)(?:[EeDd]?[-+]\d+)?|[-+]?(?i:nan|inf(?:inity)?))"
#: Relative slack of the "ascending frequencies" check, the precision ccx prints (7 significant digits,
#: so two equal roots may be printed in either order).
FREQUENCY_ORDER_RTOL = 1e-6
_EIGEN_HEADER = re.compile(r"E I G E N V A L U E\s+O U T P U T")
_EIGEN_ROW = re.compile(rf"^\s*(\d+)\s+({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})\s*$")
_MODE_HEADER = re.compile(r"E I G E N V A L U E\s+N U M B E R\s+(\d+)")
_DISP_HEADER = re.compile(r"displacements \(vx,vy,vz\) for set (\S+) and time")
_DISP_ROW = re.compile(rf"^\s*(\d+)\s+({_FLOAT})\s+({_FLOAT})\s+({_FLOAT})\s*$")


def fortran_float(token: str) -> float:
    """Parse a Fortran real, including the 3-digit-exponent form ``1.234567-101``."""
    token = token.replace("D", "E").replace("d", "e")
    try:
        return float(token)
    except ValueError:
        match = re.fullmatch(r"([-+]?\d*\.?\d*)([-+]\d+)", token)
        if match is None:
            raise ValueError(f"not a number: {token!r}") from None
        return float(f"{match.group(1)}e{match.group(2)}")


@dataclass(frozen=True)
class DatContents:
    """What a CalculiX frequency-step ``.dat`` holds.

    eigenvalues: (rad/s)², shape (n_modes,). frequencies_hz: the cycles/time column.
    displacements: ``{mode number: {SET NAME: {node: (ux, uy, uz)}}}`` (1/√kg).
    """

    eigenvalues: np.ndarray
    frequencies_hz: np.ndarray
    displacements: Mapping[int, Mapping[str, Mapping[int, tuple[float, float, float]]]]


def parse_dat(text: str, source: str = "job.dat") -> DatContents:
    """Parse the eigenvalue table and the per-mode ``*NODE PRINT`` tables of a ``.dat``.

    Raises ValueError naming ``source`` and the line when the structure is not the
    expected one (missing eigenvalue block, a row that does not parse, …).
    """
    lines = text.splitlines()
    headers = [i for i, line in enumerate(lines) if _EIGEN_HEADER.search(line)]
    if not headers:
        raise ValueError(f"{source}: no 'E I G E N V A L U E   O U T P U T' block (did the *FREQUENCY step run?)")
    if len(headers) > 1:
        raise ValueError(f"{source}: {len(headers)} eigenvalue output blocks (lines {[h + 1 for h in headers]}); expected one frequency step")
    eigenvalues, frequencies, mode_numbers = [], [], []
    started = False
    for number, line in enumerate(lines[headers[0] + 1 :], start=headers[0] + 2):
        match = _EIGEN_ROW.match(line)
        if match:
            started = True
            mode_numbers.append(int(match.group(1)))
            eigenvalues.append(fortran_float(match.group(2)))
            frequencies.append(fortran_float(match.group(4)))
        elif started:
            break
        elif line.strip() and not re.search(r"MODE|EIGENVALUE|REAL PART|RAD/TIME|CYCLES", line):
            raise ValueError(f"{source}, line {number}: expected an eigenvalue row 'mode eigenvalue rad/s Hz imag', got {line.strip()!r}")
    if not mode_numbers:
        raise ValueError(f"{source}: the eigenvalue block holds no rows")
    if mode_numbers != list(range(1, len(mode_numbers) + 1)):
        raise ValueError(f"{source}: eigenvalue rows are numbered {mode_numbers}, expected 1..{len(mode_numbers)}")

    displacements: dict[int, dict[str, dict[int, tuple[float, float, float]]]] = {}
    mode: int | None = None
    current: dict[int, tuple[float, float, float]] | None = None
    for number, line in enumerate(lines, start=1):
        header = _MODE_HEADER.search(line)
        if header:
            mode = int(header.group(1))
            displacements.setdefault(mode, {})
            current = None
            continue
        disp = _DISP_HEADER.search(line)
        if disp:
            if mode is None:
                raise ValueError(f"{source}, line {number}: displacement table before any 'E I G E N V A L U E    N U M B E R' header")
            current = displacements[mode].setdefault(disp.group(1).upper(), {})
            continue
        if current is None:
            continue
        row = _DISP_ROW.match(line)
        if row:
            current[int(row.group(1))] = (fortran_float(row.group(2)), fortran_float(row.group(3)), fortran_float(row.group(4)))
        elif line.strip():
            current = None
    return DatContents(np.asarray(eigenvalues), np.asarray(frequencies), displacements)


def check_modes(eigenvalues: np.ndarray, frequencies_hz: np.ndarray, n_modes: int) -> None:
    """ValueError unless there are exactly ``n_modes`` modes, finite eigenvalues and finite,
    non-negative, ascending frequencies (within :data:`FREQUENCY_ORDER_RTOL`)."""
    eigenvalues = np.asarray(eigenvalues, dtype=float)
    frequencies = np.asarray(frequencies_hz, dtype=float)
    if frequencies.size != n_modes or eigenvalues.size != n_modes:
        raise ValueError(f"{frequencies.size} of the {n_modes} requested modes in the output")
    bad = [i + 1 for i in range(n_modes) if not (np.isfinite(eigenvalues[i]) and np.isfinite(frequencies[i]))]
    if bad:
        raise ValueError(f"mode(s) {bad} are not finite numbers: eigenvalues {eigenvalues.tolist()} (rad/s)², "
                         f"frequencies {frequencies.tolist()} Hz")
    check_frequencies(frequencies, FREQUENCY_ORDER_RTOL)


def frequency_step(n_modes: int, node_sets: Sequence[str]) -> str:
    """The analysis step appended to every model deck (see the module docstring)."""
    prints = "".join(f"*NODE PRINT,NSET={name},GLOBAL=YES\nU\n" for name in node_sets)
    return f"*STEP\n*FREQUENCY\n{n_modes}\n{prints}*END STEP\n"


def count_elements(deck: str) -> int | None:
    """Number of continuum/structural elements in a deck (MASS, SPRING, DASHPOT excluded).

    None when an ``*ELEMENT`` block has a type this function does not know.
    """
    total = 0
    entries_needed = 0
    entries_seen = 0
    counting = False
    in_block = False
    for line in deck.splitlines():
        stripped = line.strip()
        if not stripped or stripped.startswith("**"):
            continue
        if stripped.startswith("*"):
            in_block = stripped.upper().replace(" ", "").startswith("*ELEMENT,") or stripped.upper() == "*ELEMENT"
            if in_block:
                match = re.search(r"TYPE\s*=\s*([A-Za-z0-9]+)", stripped, flags=re.IGNORECASE)
                element_type = match.group(1).upper() if match else ""
                if element_type not in _NODES_PER_ELEMENT:
                    return None
                entries_needed = _NODES_PER_ELEMENT[element_type] + 1
                counting = element_type not in _NOT_MESH
                entries_seen = 0
            continue
        if not in_block:
            continue
        entries_seen += len([item for item in stripped.split(",") if item.strip()])
        while entries_seen >= entries_needed:
            entries_seen -= entries_needed
            total += counting
    return total


def check_coordinates(coordinates: Coordinates, deck: str) -> dict[str, tuple[str, str]]:
    """Validate ``{name: (node set, direction)}`` against the deck; set names upper-cased."""
    if not coordinates:
        raise ValueError("deck generator returned no measurement coordinates; expected e.g. {'tip:uz': ('TIP', 'uz')}")
    defined = {match.upper() for match in re.findall(r"^\*NSET\s*,[^\n]*?NSET\s*=\s*([^,\s]+)", deck, flags=re.IGNORECASE | re.MULTILINE)}
    checked = {}
    for name, spec in coordinates.items():
        if not (isinstance(spec, tuple) and len(spec) == 2):
            raise ValueError(f"coordinate {name!r}: expected (node set, direction), got {spec!r}")
        node_set, direction = str(spec[0]).upper(), str(spec[1]).lower()
        if direction not in DIRECTIONS:
            raise ValueError(f"coordinate {name!r}: direction {spec[1]!r} is not one of {sorted(DIRECTIONS)}")
        if node_set not in defined:
            raise ValueError(f"coordinate {name!r}: node set {node_set!r} is not defined by an *NSET card in the deck")
        checked[name] = (node_set, direction)
    return checked


def _first_error_line(log_path: Path) -> str | None:
    """First ``*ERROR`` line of a ccx log with the line after it (None if there is none)."""
    try:
        lines = log_lines(log_path)
        for line in lines:
            if "*ERROR" in line.upper():
                following = next(lines, "").strip()
                return f"{line.strip()} {following}".strip()
    except OSError:
        return None
    return None


class CalculixAdapter(FEAdapter):
    """Modal analysis with CalculiX: one ``ccx -i job`` run per parameter point.

    deck_generator: ``parameters -> (model_text, coordinates)`` (see module docstring).
    parameter_names: names the generator accepts (all SI).
    n_modes: number of eigenpairs requested from ``*FREQUENCY``.
    work_root: directory for run directories ``<work_root>/<evaluation key>``, all kept
        (default: one private temporary folder per process, made at the first run; a run
        that succeeds is deleted from it, a failed one is kept and named in the error, and
        the folder goes when the process ends if it is empty — nothing lands in the
        working folder).
    executable: ccx program (name on PATH or path).
    timeout_s: wall-clock limit per run (s).
    threads: OMP_NUM_THREADS / CCX_NPROC_EQUATION_SOLVER given to ccx.
    model_id: model fingerprint when the generator has no ``fingerprint()``.
    negative_eigenvalue_tolerance: eigenvalues below ``-tol·max|λ|`` are errors.
    """

    name = "calculix"
    runs_a_program = True

    def __init__(
        self,
        deck_generator: DeckGenerator,
        parameter_names: Sequence[str],
        *,
        n_modes: int = 10,
        work_root: str | Path | None = None,
        executable: str = "ccx",
        timeout_s: float | None = 3600.0,
        threads: int = 1,
        model_id: str | None = None,
        negative_eigenvalue_tolerance: float = 1e-8,
    ) -> None:
        super().__init__(parameter_names)
        if not (isinstance(n_modes, int) and n_modes >= 1):
            raise ValueError(f"n_modes must be a positive integer, got {n_modes!r}")
        if not (isinstance(threads, int) and threads >= 1):
            raise ValueError(f"threads must be a positive integer, got {threads!r}")
        fingerprint = getattr(deck_generator, "fingerprint", None)
        if not callable(fingerprint) and not model_id:
            raise ValueError(
                "CalculixAdapter: the deck generator has no fingerprint() method; pass model_id=<string that "
                "changes whenever the generator changes> so cached results are not reused for another model"
            )
        self.deck_generator = deck_generator
        self.n_modes = n_modes
        self.model_id = model_id
        self.negative_eigenvalue_tolerance = negative_eigenvalue_tolerance
        self.runner = ProcessRunner(
            executable=executable,
            work_root=work_root,
            scratch_prefix="nlupdate-ccx-",
            timeout_s=timeout_s,
            env={"OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads)},
            install_hint=CCX_INSTALL_HINT,
            log_name="ccx.log",
        )

    def check_available(self) -> None:
        self.runner.resolve()

    def solver_version(self) -> str:
        return f"CalculiX {self.runner.version()}"

    def model_fingerprint(self) -> str:
        generator_fingerprint = getattr(self.deck_generator, "fingerprint", None)
        model = generator_fingerprint() if callable(generator_fingerprint) else self.model_id
        return fingerprint(model, self.n_modes, length=16)

    def write_deck(self, parameters: Mapping[str, float], run_dir: Path) -> tuple[Path, dict[str, tuple[str, str]], str]:
        """Write ``job.inp`` (model + frequency step) into ``run_dir``."""
        model, coordinates = self.deck_generator(parameters)
        if re.search(r"^\s*\*STEP\b", model, flags=re.IGNORECASE | re.MULTILINE):
            raise ValueError("deck generator output contains *STEP; it must hold model data only (the adapter appends the *FREQUENCY step)")
        checked = check_coordinates(coordinates, model)
        node_sets = list(dict.fromkeys(node_set for node_set, _ in checked.values()))
        deck = model.rstrip("\n") + "\n" + frequency_step(self.n_modes, node_sets)
        path = run_dir / f"{JOB_NAME}.inp"
        write_text_atomic(path, deck)
        return path, checked, deck

    def check_values(self, parameters: Mapping[str, float]) -> None:
        self.deck_generator(self._check(parameters))  # the generator refuses values its model cannot take

    def _solve(self, parameters: Mapping[str, float]) -> ModalResult:
        run_dir = self.runner.new_run_dir(self.key(parameters))
        _, coordinates, deck = self.write_deck(parameters, run_dir)
        try:
            run = self.runner.run(["-i", JOB_NAME], run_dir)
        except (ExecutableNotFoundError, RunTimeoutError):
            raise
        except AdapterError as error:
            first_error = _first_error_line(run_dir / self.runner.log_name)
            if first_error is None:
                raise
            raise AdapterError(f"ccx error: {first_error}\n{error}") from error
        result = self._read_result(run, coordinates, deck)
        if self.runner.work_root is None:  # the private scratch folder: nothing to keep of a run that worked
            shutil.rmtree(run_dir, ignore_errors=True)
            result = dataclasses.replace(result, metadata={**result.metadata, "log_path": None, "run_dir": None,
                                                           "dat_path": None, "files": "removed after the run (no work_root)"})
        return result

    def _read_result(self, run: RunResult, coordinates: dict[str, tuple[str, str]], deck: str) -> ModalResult:
        first_error = _first_error_line(run.log_path)
        if first_error is not None:
            raise run_failure(f"ccx reported an error although it exited with code {run.returncode}: {first_error}", run.run_dir, run.log_path)
        dat_path = run.run_dir / f"{JOB_NAME}.dat"
        if not dat_path.exists():
            raise run_failure(f"ccx finished but wrote no {dat_path.name}", run.run_dir, run.log_path)
        try:
            contents = parse_dat(dat_path.read_text(errors="replace"), str(dat_path))
        except ValueError as error:
            raise run_failure(f"could not read the ccx results: {error}", run.run_dir, run.log_path) from error
        eigenvalues = contents.eigenvalues
        try:
            check_modes(eigenvalues, contents.frequencies_hz, self.n_modes)
        except ValueError as error:
            raise run_failure(f"ccx returned unusable modes in {dat_path.name}: {error}", run.run_dir, run.log_path) from None
        scale = float(np.max(np.abs(eigenvalues)))
        negative = np.flatnonzero(eigenvalues < -self.negative_eigenvalue_tolerance * scale)
        if negative.size:
            raise run_failure(
                f"ccx found negative eigenvalues for modes {(negative + 1).tolist()} ({eigenvalues[negative].tolist()} (rad/s)²): "
                "the model has a mechanism (hourglassing, missing supports or unconnected parts)",
                run.run_dir,
                run.log_path,
            )
        n_modes = eigenvalues.size
        shapes = np.empty((len(coordinates), n_modes))
        for row, (name, (node_set, direction)) in enumerate(coordinates.items()):
            for mode in range(1, n_modes + 1):
                table = contents.displacements.get(mode, {}).get(node_set)
                if not table:
                    raise run_failure(
                        f"{dat_path.name} has no displacement table for node set {node_set} in mode {mode} (coordinate {name!r})",
                        run.run_dir,
                        run.log_path,
                    )
                shapes[row, mode - 1] = float(np.mean([values[DIRECTIONS[direction]] for values in table.values()]))
        if not np.all(np.isfinite(shapes)):
            rows, modes = np.nonzero(~np.isfinite(shapes))
            bad = sorted({(list(coordinates)[r], int(m) + 1) for r, m in zip(rows, modes)})
            raise run_failure(f"ccx returned displacements that are not finite numbers in {dat_path.name} "
                              f"(coordinate, mode): {bad}", run.run_dir, run.log_path)
        metadata = {
            "solver": "calculix",
            "mesh_size": count_elements(deck),
            "wall_time_s": run.wall_time_s,
            "log_path": str(run.log_path),
            "run_dir": str(run.run_dir),
            "dat_path": str(dat_path),
            "eigenvalues_rad2_s2": eigenvalues.tolist(),
            "nodes_per_coordinate": {
                name: len(contents.displacements[1][node_set]) for name, (node_set, _) in coordinates.items()
            },
        }
        return ModalResult(
            natural_frequencies_hz=np.asarray(contents.frequencies_hz, dtype=float),
            mode_shapes=shapes,
            coordinates=tuple(coordinates),
            metadata=metadata,
        )
