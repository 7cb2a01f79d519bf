"""nlupdate's runs never send usage telemetry: Prefect ≥ 3.6 starts an SDK telemetry service on
import (outside CI, unless ``DO_NOT_TRACK`` is set), and its server sends usage data unless
``PREFECT_SERVER_ANALYTICS_ENABLED`` is false; the run's environment sets both before Prefect
is imported (docs/safety.md)."""
from __future__ import annotations

import json
import os
import subprocess
import sys

CHECK = """
import argparse, json, os, sys
from nlupdate.app.cli.run import prefect_errors
assert "prefect" not in sys.modules
with prefect_errors(argparse.Namespace()):  # what every Prefect command of the CLI runs in
    import prefect  # noqa: F401
    from prefect._internal.analytics import is_telemetry_enabled
    print(json.dumps({"client": is_telemetry_enabled(), "DO_NOT_TRACK": os.environ.get("DO_NOT_TRACK"),
                      "server": os.environ.get("PREFECT_SERVER_ANALYTICS_ENABLED")}))
"""

def test_a_command_imports_prefect_with_its_telemetry_off_outside_ci():
    from prefect._internal.analytics.ci_detection import CI_ENV_VARS

    env = {name: value for name, value in os.environ.items()
           if name not in CI_ENV_VARS and name not in ("DO_NOT_TRACK", "PREFECT_SERVER_ANALYTICS_ENABLED")}
    done = subprocess.run([sys.executable, "-c", CHECK], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    found = json.loads(done.stdout.strip().splitlines()[-1])
    assert found == {"client": False, "DO_NOT_TRACK": "1", "server": "false"}
