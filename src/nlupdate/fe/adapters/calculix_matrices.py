"""The stiffness and mass matrices of a CalculiX model (``*FREQUENCY, SOLVER=MATRIXSTORAGE``).

A reduction exact at a joint (:mod:`nlupdate.fe.reduction`) needs the model's matrices,
not only a few of its modes. ccx writes them when the frequency step names the
``MATRIXSTORAGE`` solver: ``job.sti`` (stiffness, N/m) and ``job.mas`` (mass, kg), one
entry ``row column value`` per line of the upper triangle, 1-based, 14 significant
digits, and ``job.dof`` naming each row ``node.direction`` (direction 1, 2, 3 = x, y, z
translation). Reduced-integration bricks (C3D20R, C3D8R) are refused: ccx integrates their
mass at the reduced points too, so the mass matrix is singular (a 600-dof two-beam C3D20R
model gave a mass matrix that is not positive definite, and ccx itself, asked for 20 modes
of it, returned negative eigenvalues). Constrained dofs (``*BOUNDARY``) are not in the matrices; the model data
must hold no multi-point constraints (``*EQUATION``, ``*RIGID BODY``, beam or shell
elements, which ccx expands into constrained solids): the matrices would then act on
ccx's internal dofs. Checked against the eigenvalues ccx itself computes from the same
deck (tests/test_calculix_reduction.py).
"""
from __future__ import annotations

import re
import shutil
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import scipy.sparse

from nlupdate.fe.adapters.calculix import CCX_INSTALL_HINT, JOB_NAME, _first_error_line
from nlupdate.fe.adapters.runner import ProcessRunner, run_failure, write_text_atomic

#: The analysis step that makes ccx write the matrices and stop (no eigenvalues solved).
MATRIX_STEP = "*STEP\n*FREQUENCY, SOLVER=MATRIXSTORAGE\n1\n*END STEP\n"

_CONSTRAINTS = re.compile(r"^\s*\*(EQUATION|RIGID\s*BODY|MPC|COUPLING|TIE)\b", flags=re.IGNORECASE | re.MULTILINE)
_STRUCTURAL = re.compile(r"^\s*\*ELEMENT\b[^\n]*TYPE\s*=\s*(B3|S3|S4|S6|S8)", flags=re.IGNORECASE | re.MULTILINE)
_REDUCED = re.compile(r"^\s*\*ELEMENT\b[^\n]*TYPE\s*=\s*(C3D20R|C3D8R)\b", flags=re.IGNORECASE | re.MULTILINE)


@dataclass(frozen=True, eq=False)
class FullMatrices:
    """Assembled matrices of a CalculiX model.

    stiffness: (n, n) N/m, mass: (n, n) kg, both symmetric ``scipy.sparse.csr_matrix``.
    nodes, directions: (n,) node number and direction (1 = x, 2 = y, 3 = z) of each row.
    """

    stiffness: scipy.sparse.csr_matrix
    mass: scipy.sparse.csr_matrix
    nodes: np.ndarray
    directions: np.ndarray

    @property
    def n_dof(self) -> int:
        return self.stiffness.shape[0]

    def index(self, node: int, direction: int) -> int:
        """Row of ``node``'s ``direction`` (1, 2, 3); ValueError when it is constrained or absent."""
        found = np.flatnonzero((self.nodes == node) & (self.directions == direction))
        if found.size != 1:
            raise ValueError(f"node {node} direction {direction} is not a free dof of the model "
                             "(constrained by *BOUNDARY, or no element uses the node)")
        return int(found[0])

    def rows(self, nodes: np.ndarray, direction: int) -> np.ndarray:
        """Rows of ``direction`` (1, 2, 3) for every node of ``nodes``, in that order."""
        lookup = {(int(n), int(d)): i for i, (n, d) in enumerate(zip(self.nodes, self.directions))}
        try:
            return np.array([lookup[(int(node), direction)] for node in nodes], dtype=int)
        except KeyError as error:
            raise ValueError(f"node {error.args[0][0]} direction {direction} is not a free dof of the model") from None


def parse_dof_file(text: str, source: str = "job.dof") -> tuple[np.ndarray, np.ndarray]:
    """Node numbers and directions of the rows from a ``.dof`` file (``node.direction`` lines)."""
    nodes, directions = [], []
    for number, line in enumerate(text.splitlines(), start=1):
        token = line.strip()
        if not token:
            continue
        match = re.fullmatch(r"(\d+)\.(\d+)", token)
        if match is None:
            raise ValueError(f"{source}, line {number}: expected 'node.direction', got {token!r}")
        nodes.append(int(match.group(1)))
        directions.append(int(match.group(2)))
    if not nodes:
        raise ValueError(f"{source}: no rows")
    return np.asarray(nodes), np.asarray(directions)


def parse_matrix_file(text: str, n: int, source: str) -> scipy.sparse.csr_matrix:
    """Symmetric (n, n) matrix from the upper-triangle ``row column value`` lines ccx writes."""
    try:
        table = np.loadtxt(text.splitlines(), ndmin=2) if text.strip() else np.empty((0, 3))
    except ValueError as error:
        raise ValueError(f"{source}: not a table of 'row column value' lines ({error})") from None
    if table.shape[1] != 3:
        raise ValueError(f"{source}: expected 3 columns 'row column value', got {table.shape[1]}")
    rows, columns, values = table[:, 0].astype(int) - 1, table[:, 1].astype(int) - 1, table[:, 2]
    if rows.size and (rows.min() < 0 or columns.min() < 0 or max(rows.max(), columns.max()) >= n):
        raise ValueError(f"{source}: an index is outside 1..{n} (the .dof file's rows)")
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{source}: entries that are not finite numbers")
    upper = scipy.sparse.coo_matrix((values, (rows, columns)), shape=(n, n)).tocsr()
    return (upper + scipy.sparse.triu(upper, k=1).T).tocsr()


def read_matrices(run_dir: Path, job: str = JOB_NAME) -> FullMatrices:
    """The matrices ccx wrote into ``run_dir`` (``job.sti``, ``job.mas``, ``job.dof``)."""
    nodes, directions = parse_dof_file((run_dir / f"{job}.dof").read_text(), str(run_dir / f"{job}.dof"))
    n = nodes.size
    stiffness = parse_matrix_file((run_dir / f"{job}.sti").read_text(), n, str(run_dir / f"{job}.sti"))
    mass = parse_matrix_file((run_dir / f"{job}.mas").read_text(), n, str(run_dir / f"{job}.mas"))
    return FullMatrices(stiffness, mass, nodes, directions)


def check_model_data(model: str) -> None:
    """ValueError when the model data hold a step or constraints the matrices cannot carry."""
    if re.search(r"^\s*\*STEP\b", model, flags=re.IGNORECASE | re.MULTILINE):
        raise ValueError("model data contain *STEP; they must hold the model only (the matrix step is appended)")
    match = _CONSTRAINTS.search(model) or _STRUCTURAL.search(model)
    if match:
        raise ValueError(f"model data contain {match.group(0).strip()!r}: ccx would write the matrices of its "
                         "constrained internal dofs; mesh with solid elements and give joints as node pairs")
    match = _REDUCED.search(model)
    if match:
        raise ValueError(f"model data contain {match.group(0).strip()!r}: ccx integrates a reduced-integration "
                         "element's mass at its reduced points too, which leaves the mass matrix singular; use "
                         "C3D20")


class CalculixMatrices:
    """One ``ccx`` run per model that returns its :class:`FullMatrices`.

    work_root, executable, timeout_s, threads: as :class:`~nlupdate.fe.adapters.calculix.CalculixAdapter`
    (a run directory is deleted after a successful run when ``work_root`` is None).
    """

    def __init__(self, *, work_root: str | Path | None = None, executable: str = "ccx",
                 timeout_s: float | None = 3600.0, threads: int = 1) -> None:
        self.runner = ProcessRunner(
            executable=executable, work_root=work_root, scratch_prefix="nlupdate-ccx-", timeout_s=timeout_s,
            env={"OMP_NUM_THREADS": str(threads), "CCX_NPROC_EQUATION_SOLVER": str(threads)},
            install_hint=CCX_INSTALL_HINT, log_name="ccx.log",
        )

    def check_available(self) -> None:
        self.runner.resolve()

    def assemble(self, model: str, name: str) -> FullMatrices:
        """Matrices of ``model`` (CalculiX model data, SI units, no ``*STEP``); ``name`` names the run folder."""
        check_model_data(model)
        run_dir = self.runner.new_run_dir(name)
        write_text_atomic(run_dir / f"{JOB_NAME}.inp", model.rstrip("\n") + "\n" + MATRIX_STEP)
        run = self.runner.run(["-i", JOB_NAME], run_dir)
        error = _first_error_line(run.log_path)
        if error is not None:
            raise run_failure(f"ccx reported an error: {error}", run.run_dir, run.log_path)
        try:
            matrices = read_matrices(run.run_dir)
        except (OSError, ValueError) as problem:
            raise run_failure(f"could not read the matrices ccx wrote: {problem}", run.run_dir, run.log_path) from None
        if self.runner.work_root is None:
            shutil.rmtree(run_dir, ignore_errors=True)
        return matrices
