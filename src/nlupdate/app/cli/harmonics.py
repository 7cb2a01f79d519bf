"""``--method hb --harmonics H [--samples N] [--no-stability]``: the response method on the
command line (``simulate``, ``discover``), checked by the rules of
:mod:`nlupdate.core.response.method`."""
from __future__ import annotations

import argparse

from nlupdate.app.cli import CliError
from nlupdate.core.response.harmonic_balance import HarmonicSettings
from nlupdate.core.response.method import HARMONICS_FORM, samples_form, valid_harmonics, valid_samples

_HB_OPTIONS = (("harmonics", "--harmonics"), ("samples", "--samples"), ("no_stability", "--no-stability"))


def harmonics_count(text: str) -> int | str:
    """``--harmonics``: an integer ≥ 1 or ``auto``."""
    value: int | str = text.strip()
    if value != "auto":
        try:
            value = int(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected {HARMONICS_FORM}, got {text!r}") from None
    if not valid_harmonics(value):
        raise argparse.ArgumentTypeError(f"expected {HARMONICS_FORM}, got {text!r}")
    return value


def _count(text: str) -> int:
    try:
        return int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected an integer (samples per period), got {text!r}") from None


def add_harmonic_options(parser: argparse.ArgumentParser) -> None:
    """``--harmonics``, ``--samples`` and ``--no-stability`` (for ``--method hb``)."""
    group = parser.add_argument_group("harmonic balance (--method hb)")
    group.add_argument("--harmonics", type=harmonics_count, metavar="H",
                       help='harmonics of the balance: an integer ≥ 1 or "auto" (raised until the highest carry '
                            "≤ 0.1 %% of the response); default 3")
    group.add_argument("--samples", type=_count, metavar="N",
                       help="time samples per period of the force evaluation, > 2·H (default: a power of two "
                            "≥ max(64, 8·(H+1)))")
    group.add_argument("--no-stability", action="store_true",
                       help="skip the Floquet multipliers (stability from the Jacobian's sign, no bifurcations)")


def harmonic_settings(args: argparse.Namespace) -> HarmonicSettings | None:
    """The settings of ``--method hb`` (None for any other method); a harmonic-balance option
    with another method, or too few samples, is a :class:`CliError`."""
    if args.method != "hb":
        given = [flag for name, flag in _HB_OPTIONS if getattr(args, name) not in (None, False)]
        if given:
            raise CliError(f"{given[0]} applies to --method hb (harmonic balance), not --method {args.method}")
        return None
    harmonics = args.harmonics if args.harmonics is not None else HarmonicSettings.harmonics
    if not valid_samples(args.samples, harmonics):
        raise CliError(f"argument --samples: expected {samples_form(harmonics)}, got {args.samples}")
    return HarmonicSettings(harmonics=harmonics, samples=args.samples, stability=not args.no_stability)
