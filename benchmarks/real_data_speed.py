"""How long a test engineer waits: identify, amplitude and validate on one mode of the Brake–Reuss beam.

    python benchmarks/real_data_speed.py [--only SUBSTRING] [--rounds N] [--samples N]

Runs each command as ``nlupdate …`` in its own process on the public Brake–Reuss beam
(tests/data/brb/ForcedFrequencyResponses.mat, four force-controlled levels around the first
bending mode; issue 39, goal: ≤ 30 s idle, Monte-Carlo samples included) and prints one row
per command: wall and CPU time (the process and its children), the model evaluations (calls
of the residual of every ``scipy.optimize.least_squares`` fit, and of its Jacobian when it is
given), the Monte-Carlo samples (the totals the command's progress reports: Monte-Carlo
samples of identify, bootstrap refits of amplitude, held-out levels and jackknife refits of
validate), the CPU per sample and per model evaluation, and met / NOT met against 30 s —
decided on CPU time, since wall time on a shared machine measures the other work too. The
load average is printed before and after. With ``--rounds N`` each command runs N times,
interleaved, and the medians are printed. ``--write-docs``: the output becomes its block of
docs/performance.md (benchmarks/docs_block.py).
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

if __package__ in (None, ""):  # run as a script: make the repository root importable
    sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import docs_block  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
BRB = ROOT / "tests" / "data" / "brb" / "ForcedFrequencyResponses.mat"
LIMIT_S = 30.0
ELEMENT_SETS = ("polynomial", "cubic", "jenkins", "iwan", "gap", "coulomb", "quadratic_damping",
                "cubic+jenkins", "cubic+iwan")
VALIDATE_MODELS = ("auto", "lines", "amplitude-polynomial", "amplitude-iwan", "prd:cubic", "prd:jenkins",
                   "prd:iwan", "prd:cubic+jenkins")


def commands() -> list[tuple[str, list[str]]]:
    """(label, arguments after ``nlupdate``) of every command measured; ``{out}`` is the output folder."""
    measured = ["--measured", str(BRB), "--coordinates", f"{BRB}=acc3:-y,acc3:y"]
    rows: list[tuple[str, list[str]]] = []
    for method in ("prd", "ddf"):
        for elements in ELEMENT_SETS:
            chosen = [] if elements == "polynomial" else ["--elements", elements.replace("+", ",")]
            rows.append((f"identify --method {method} --elements {elements}",
                         ["identify", *measured, "--method", method, *chosen, "--out", "{out}"]))
    for backbone in ("polynomial", "iwan"):
        rows.append((f"amplitude --backbone {backbone}", ["amplitude", *measured, "--backbone", backbone,
                                                           "--out", "{out}"]))
        if backbone == "polynomial":  # a band cut into the file: each level read again on the whole band, 30 noisy copies
            rows.append(("amplitude --backbone polynomial --band 80:80.6",
                         ["amplitude", *measured, "--band", "80:80.6", "--backbone", backbone, "--out", "{out}"]))
        rows.append((f"amplitude --backbone {backbone} --response-controlled",
                     ["amplitude", "--response-controlled", str(BRB), *measured[2:], "--backbone", backbone,
                      "--out", "{out}"]))
    for model in VALIDATE_MODELS:
        rows.append((f"validate --hold-out each --model {model}",
                     ["validate", *measured, "--hold-out", "each", "--model", model, "--out", "{out}"]))
    return rows


def child(argv: list[str], record: str) -> int:
    """Run ``nlupdate argv`` in this process, counting model evaluations and progress totals."""
    import scipy.optimize

    counts = {"evaluations": 0, "progress": {}}
    original = scipy.optimize.least_squares

    def counted(fun, x0, jac="2-point", *args, **kwargs):
        def counted_fun(*a, **k):
            counts["evaluations"] += 1
            return fun(*a, **k)
        if callable(jac):
            inner = jac

            def jac(*a, **k):  # noqa: E306 - an analytic Jacobian is one more evaluation of the model
                counts["evaluations"] += 1
                return inner(*a, **k)
        return original(counted_fun, x0, jac, *args, **kwargs)

    scipy.optimize.least_squares = counted
    import contextlib

    import nlupdate.app.cli.progress_bar as bars

    @contextlib.contextmanager
    def recording():
        def update(task: str, done: int, total: int) -> None:
            counts["progress"][task] = max(total, counts["progress"].get(task, 0))
        yield update

    bars.terminal_progress = recording
    from nlupdate.app.cli import main
    try:
        code = main(argv)
    finally:
        Path(record).write_text(json.dumps(counts))
    return code


def samples_of(progress: dict[str, int]) -> int:
    """Monte-Carlo samples (or refits standing for them) among the progress totals."""
    return sum(total for task, total in progress.items()
               if any(word in task.lower() for word in ("monte-carlo", "bootstrap", "jackknife")))


def measure(label: str, argv: list[str], folder: Path) -> dict:
    out = folder / f"out{len(list(folder.iterdir()))}"
    record = folder / f"{out.name}.json"
    args = [a.replace("{out}", str(out)) for a in argv]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    result = subprocess.run([sys.executable, __file__, "--child", str(record), "--", *args],
                            capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    counts = json.loads(record.read_text()) if record.exists() else {"evaluations": 0, "progress": {}}
    if result.returncode != 0:
        last = (result.stderr.strip().splitlines() or ["?"])[-1]
        print(f"  {label}: exit {result.returncode}: {last}", file=sys.stderr)
    print(f"  {label}: {wall:.1f} s wall, {cpu:.1f} s CPU, load {load()}", file=sys.stderr, flush=True)
    return {"label": label, "wall": wall, "cpu": cpu, "code": result.returncode,
            "evaluations": counts["evaluations"], "samples": samples_of(counts["progress"]),
            "progress": counts["progress"]}


def load() -> str:
    return "/".join(f"{v:.1f}" for v in os.getloadavg())


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    if argv[:1] == ["--child"]:
        return child(argv[3:], argv[1])
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--only", action="append", default=[],
                        help="measure only commands whose label contains this (repeatable)")
    parser.add_argument("--rounds", type=int, default=1, help="interleaved runs per command (medians)")
    parser.add_argument("--samples", type=int, default=None,
                        help="identify: --samples N (default: the command's own default)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows to this file")
    docs_block.add_option(parser)
    args = parser.parse_args(argv)
    with docs_block.writing_docs(args.write_docs, "real_data_speed.py", argv):
        rows = measure_all(args)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


def measure_all(args: argparse.Namespace) -> list[dict]:
    """Run the chosen commands ``args.rounds`` times, interleaved; print the table; its rows."""
    chosen = [(label, a) for label, a in commands() if not args.only or any(s in label for s in args.only)]
    if args.samples is not None:
        chosen = [(label, a + ["--samples", str(args.samples)] if a[0] == "identify" else a) for label, a in chosen]
    print(f"Brake–Reuss beam, {BRB.relative_to(ROOT)}; {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
          f"load {load()} (1/5/15 min); {os.cpu_count()} cores; {args.rounds} round(s)", flush=True)
    runs: dict[str, list[dict]] = {label: [] for label, _ in chosen}
    with tempfile.TemporaryDirectory() as tmp:
        for round_ in range(args.rounds):
            order = chosen if round_ % 2 == 0 else chosen[::-1]
            for label, a in order:
                runs[label].append(measure(label, a, Path(tmp)))
    print(f"load after: {load()}\n")
    print("| command | wall (s) | CPU (s) | model evaluations | Monte-Carlo samples | CPU per sample (ms) "
          "| CPU per model evaluation (ms) | ≤ 30 s |")
    print("|---|---|---|---|---|---|---|---|")
    rows = []
    for label, _ in chosen:
        done = runs[label]
        wall = statistics.median(r["wall"] for r in done)
        cpu = statistics.median(r["cpu"] for r in done)
        evaluations, samples = done[0]["evaluations"], done[0]["samples"]
        per_sample = f"{1e3 * cpu / samples:.0f}" if samples else "–"
        per_eval = f"{1e3 * cpu / evaluations:.2f}" if evaluations else "–"
        verdict = "failed" if any(r["code"] for r in done) else ("met" if cpu <= LIMIT_S else "NOT met")
        print(f"| `{label}` | {wall:.1f} | {cpu:.1f} | {evaluations} | {samples} | {per_sample} | {per_eval} "
              f"| {verdict} |", flush=True)
        rows.append({**done[0], "wall": wall, "cpu": cpu, "verdict": verdict})
    largest = max(rows, key=lambda row: row["cpu"])
    every = all(row["verdict"] == "met" for row in rows)
    print(f"\ngoal: every command ≤ {LIMIT_S:.0f} s (CPU): {'met' if every else 'NOT met'}; the largest "
          f"`{largest['label']}` {largest['cpu']:.1f} s CPU, {largest['wall']:.1f} s wall")
    return rows


if __name__ == "__main__":
    sys.exit(main())
