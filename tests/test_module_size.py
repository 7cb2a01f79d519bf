"""Small modules with one purpose (issue 36): no source of the package is over 500 lines
unless :data:`LONG_MODULES` states why."""
from __future__ import annotations

from pathlib import Path

import nlupdate

PACKAGE = Path(nlupdate.__file__).parent
LIMIT = 500
#: Modules allowed over the limit, each with the reason (none today).
LONG_MODULES: dict[str, str] = {}


def test_no_module_is_over_500_lines_without_a_stated_reason():
    long = {path.relative_to(PACKAGE).as_posix(): len(path.read_text().splitlines())
            for path in PACKAGE.rglob("*.py")}
    assert {name: n for name, n in long.items() if n > LIMIT and name not in LONG_MODULES} == {}
    assert all(reason for reason in LONG_MODULES.values())
