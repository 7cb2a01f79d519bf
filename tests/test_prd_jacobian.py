"""PRD's output-error fit takes its Jacobian from the solved amplitudes; checked here against
central differences of the residual, which solve the amplitudes again.

The data are the README's identify example (2-DOF, cubic + Jenkins, 5 % noise; simulated by
the README's own `nlupdate simulate` command). Every output-error fit of the run (the
estimate and its Monte-Carlo samples) is checked at its start; differences with two steps
bound how well the residual can be differentiated there.
"""
from __future__ import annotations

import numpy as np
import scipy.optimize
from scipy.optimize._numdiff import approx_derivative  # scipy 1.11 has no public name for it

import nlupdate.core.identification.prd as prd
from nlupdate.app.cli import main
from test_readme_identify import readme_commands


def _relative(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.linalg.norm(a - b) / np.linalg.norm(b))


def test_the_output_error_jacobian_equals_central_differences(tmp_path, monkeypatch, capsys):
    least_squares = scipy.optimize.least_squares
    checked = []

    def checking(fun, x0, jac="2-point", **options):
        if callable(jac):
            fine = approx_derivative(fun, x0, method="3-point", rel_step=1e-6)
            coarse = approx_derivative(fun, x0, method="3-point", rel_step=1e-5)
            checked.append((_relative(jac(x0), fine), _relative(coarse, fine)))
        return least_squares(fun, x0, jac=jac, **options)

    monkeypatch.setattr(prd.scipy.optimize, "least_squares", checking)
    monkeypatch.chdir(tmp_path)
    commands = readme_commands()
    assert main(commands["simulate"]) == 0
    assert main(commands["identify"] + ["--samples", "5"]) == 0
    capsys.readouterr()

    assert len(checked) >= 6, checked
    for analytic, differences in checked:
        # as close to the differences as they are to each other (and never far)
        assert analytic < max(3 * differences, 1e-6) and analytic < 1e-3, checked
