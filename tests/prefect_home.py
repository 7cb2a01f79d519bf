"""A migrated Prefect database made once per test session and copied into each fresh ``PREFECT_HOME``.

A Prefect server on an empty ``PREFECT_HOME`` first runs all of Prefect's database
migrations: 6.5 s of CPU here (a server on a migrated database answers after 3.5 s instead
of 10.6 s). The suite starts a server on an empty home in every pytest-xdist worker and in
the scheduling tests; the migrations are the same each time, so :func:`start_template`
runs them once, in a subprocess started when the session starts (it runs while the workers
import and collect the tests), and :func:`seed` copies the result into a home before a
server first opens it.

Only sessions with pytest-xdist workers make the template (a lone test file run alone migrates
its one home itself rather than wait). A user's first run still meets an empty home; the slow demo test
(``test_nlupdate_demo_runs_and_a_rerun_is_all_cached``) and the README's
fresh-machine check run that path. Test scaffolding only; nothing in the package uses this.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

#: the environment variable naming the template folder; nested pytest runs inherit it
VARIABLE = "NLUPDATE_TEST_PREFECT_TEMPLATE"

_MIGRATE = """
import asyncio, os
from pathlib import Path
home = Path(os.environ["PREFECT_HOME"])
try:
    from prefect.server.database import provide_database_interface
    asyncio.run(provide_database_interface().create_db())
    os.replace(home / "prefect.db", home / "ready.db")
except BaseException as error:
    (home / "failed").write_text(f"{type(error).__name__}: {error}")
    raise
"""


def start_template() -> subprocess.Popen | None:
    """Start migrating a database into a new template folder named by :data:`VARIABLE`;
    None when an outer session's template is already named (a nested pytest run)."""
    if os.environ.get(VARIABLE):
        return None
    folder = tempfile.mkdtemp(prefix="nlupdate-test-prefect-template-")
    os.environ[VARIABLE] = folder
    env = {**os.environ, "PREFECT_HOME": folder, "PREFECT_SERVER_ANALYTICS_ENABLED": "false"}
    return subprocess.Popen([sys.executable, "-c", _MIGRATE], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)


def seed(home: str | os.PathLike, timeout_s: float = 120.0) -> bool:
    """Copy the template database into ``home`` unless it has a database already; waits
    for the template while it is being made. False (and ``home`` untouched) when there is
    no template or making it failed — the server then migrates an empty home itself."""
    folder = os.environ.get(VARIABLE)
    target = Path(home) / "prefect.db"
    if not folder or target.exists():
        return False
    ready = Path(folder) / "ready.db"
    deadline = time.monotonic() + timeout_s
    while not ready.exists():
        if (Path(folder) / "failed").exists() or time.monotonic() > deadline or not Path(folder).is_dir():
            return False
        time.sleep(0.1)
    target.parent.mkdir(parents=True, exist_ok=True)
    partial = target.with_name("prefect.db.partial")
    shutil.copyfile(ready, partial)
    os.replace(partial, target)
    return True


def remove_template(process: subprocess.Popen | None) -> None:
    """End the migration if it still runs and remove the template this session made."""
    if process is None:
        return
    if process.poll() is None:
        process.kill()
    process.wait()
    shutil.rmtree(os.environ.pop(VARIABLE), ignore_errors=True)
