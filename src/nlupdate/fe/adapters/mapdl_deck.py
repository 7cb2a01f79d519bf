"""The user's parametric APDL deck: its unit system and how parameter values get into it.

Deck rules
----------
The deck builds the model (geometry, mesh, materials, supports) in one consistent unit
system and does not solve. Every updating parameter must be defined by exactly one
``*SET,NAME,value`` line (one value, on a line of its own, at most a ``!`` comment after
it); ``NAME`` is the parameter's APDL name in the deck, by default the parameter name
itself (``apdl_names`` of the adapter). Decks where a parameter has no such line,
several, or is also assigned with ``NAME = …``, ``*GET,NAME,…``, ``*DIM,NAME,…``,
``*DO,NAME,…``, ``*ASK,NAME,…`` or ``*VGET,NAME,…`` are refused, and so are decks using
names that start with ``NLU_`` (reserved for the generated commands).

Parameter values
----------------
The adapter never uses a project parameter name, nor the deck's own name, as the name
it sets. Parameter ``i`` (1-based, in ``parameter_names`` order) is carried by the safe
APDL name ``NLU_P<i>`` (a letter first, letters/digits/underscore, ≤ 32 characters),
and the deck's line is rewritten in place into two lines::

    *SET,NLU_P1,190000000000.0   ! nlupdate parameter E     (generated)
    *SET,E,NLU_P1        ! Young's modulus (Pa)             (the user's line)

so the deck's name (``E`` here, which is also an APDL command) keeps its spelling,
position and comment — whatever the deck computes from it before and after is
unchanged — and gets the value through the generated name, defined on the line just
before (so a ``/CLEAR`` earlier in the deck cannot delete it). Values are written with
``repr(float)``: the shortest text that reads back as the same double. They are written
as given: state them in the deck's units (E in MPa for an ``mm-t-s`` deck).

Units
-----
``units`` names the deck's consistent unit system (MAPDL itself has none):

=========  ======  =====  =====  =====  ===============
units      length  mass   time   force  stress, modulus
=========  ======  =====  =====  =====  ===============
SI         m       kg     s      N      Pa
mm-t-s     mm      t      s      N      MPa (N/mm²)
mm-kg-s    mm      kg     s      mN     kPa (mN/mm²)
=========  ======  =====  =====  =====  ===============

(mm-kg-s is consistent: 1 kg·mm/s² = 1e-3 N = 1 mN and 1 mN/mm² = 1 kPa; densities in
kg/mm³.) Results are converted to the adapter's SI interface:

* frequencies: every system uses the second, so Hz need no conversion.
* mass-normalised shapes: MAPDL scales each mode to φᵀMφ = 1 with M in the deck's mass
  unit. For a translational coordinate M holds masses, so φ² has the unit 1/mass:
  ``[φ] = 1/√(deck mass unit)``, whatever the length unit. With ``c`` = deck mass units
  per kilogram (1e-3 for tonnes: 2 kg = 0.002 t), M_deck = c·M_SI and
  φ_deckᵀ M_deck φ_deck = 1 = φ_SIᵀ M_SI φ_SI, so **φ_SI = √c · φ_deck**: × 1/√1000 =
  × 0.0316228 for mm-t-s, × 1 for mm-kg-s and SI. Check by the receptance
  H = Σ φ_j φ_k / (ω_r² − ω²) (displacement per force): in mm-t-s it comes out in
  mm/N = 1e-3 m/N, so φ_SI² = 1e-3 φ_deck², the same factor; in mm-kg-s it comes out in
  mm/mN = m/N, factor 1. (A factor 1e-3/√1000 would treat φ as a length; it is not — the
  displacement is φ times a modal coordinate in √mass·length. A rotation would carry a
  length factor; only ux|uy|uz are read.)
* points: ``(x, y, z)`` in metres are written into ``NODE()`` × 1000 for mm decks;
  locations read back are converted to metres; ``location_tolerance_m`` is in metres.
* parameter values: not converted (see above).
"""
from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass

from nlupdate.fe.adapters.calculix import fortran_float

APDL_NAME = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,31}")
RESERVED_PREFIX = "NLU_"
_RESERVED_USE = re.compile(r"(?<![A-Za-z0-9_])NLU_\w*", re.IGNORECASE)
_NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?"
_NODE_POINT = re.compile(rf"NODE\(\s*({_NUMBER})\s*,\s*({_NUMBER})\s*,\s*({_NUMBER})\s*\)", re.IGNORECASE)
_DEFINING_COMMANDS = ("*GET", "*DIM", "*DO", "*ASK", "*VGET")
NodeSpec = int | str | tuple[float, float, float]


@dataclass(frozen=True)
class DeckUnits:
    """A consistent unit system of an APDL deck.

    per_metre: deck length units per metre (1 for m, 1000 for mm).
    per_kilogram: deck mass units per kilogram (1 for kg, 1e-3 for t).
    """

    name: str
    per_metre: float
    per_kilogram: float
    description: str

    @property
    def shape_factor(self) -> float:
        """φ_SI (1/√kg) = shape_factor × φ_deck (1/√deck mass unit): √per_kilogram (this module's docstring)."""
        return math.sqrt(self.per_kilogram)


UNIT_SYSTEMS: dict[str, DeckUnits] = {
    "SI": DeckUnits("SI", 1.0, 1.0, "m, kg, s, N, Pa"),
    "mm-t-s": DeckUnits("mm-t-s", 1000.0, 1e-3, "mm, t, s, N, MPa"),
    "mm-kg-s": DeckUnits("mm-kg-s", 1000.0, 1.0, "mm, kg, s, mN, kPa"),
}


def deck_units(name: str) -> DeckUnits:
    """The :class:`DeckUnits` called ``name`` (case-insensitive), or ValueError."""
    for key, units in UNIT_SYSTEMS.items():
        if isinstance(name, str) and name.lower() == key.lower():
            return units
    raise ValueError(f"units: expected one of {list(UNIT_SYSTEMS)}, got {name!r}")

def safe_parameter_name(index: int) -> str:
    """The APDL name that carries parameter number ``index`` (1-based): ``NLU_P<index>``."""
    return f"{RESERVED_PREFIX}P{index}"

def _statements(line: str) -> list[str]:
    """The ``$``-separated statements of one APDL line, without its ``!`` comment."""
    return [part.strip() for part in line.split("!", 1)[0].split("$")]

def _comment_text(name: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.:+-]", "_", name)[:60]

def check_reserved_names(deck: str) -> None:
    """ValueError when the deck uses a name starting with ``NLU_`` (reserved)."""
    for number, line in enumerate(deck.splitlines(), start=1):
        match = _RESERVED_USE.search(line.split("!", 1)[0])
        if match:
            raise ValueError(
                f"APDL deck, line {number}: {match.group(0)!r} — names starting with {RESERVED_PREFIX!r} are reserved "
                f"for the adapter's generated commands; rename it"
            )

def substitute_parameters(
    deck: str,
    values: Mapping[str, float],
    apdl_names: Mapping[str, str] | None = None,
    safe_names: Mapping[str, str] | None = None,
) -> str:
    """Set every parameter in ``values`` through its safe name (this module's docstring).

    The deck's ``*SET,NAME,value`` line of a parameter becomes ``*SET,<safe>,<value>``
    followed by ``*SET,NAME,<safe>`` (the line's own spacing and comment kept).
    apdl_names: ``{parameter: name in the deck}`` (default: the parameter name).
    safe_names: ``{parameter: generated name}`` (default ``NLU_P<i>`` in ``values``
    order; the adapter passes its own, numbered in ``parameter_names`` order).

    Raises ValueError when a parameter has no ``*SET`` line, more than one, one with
    more than one value or statement, or is also defined another way.
    """
    apdl_names = apdl_names or {}
    safe_names = safe_names or {name: safe_parameter_name(i) for i, name in enumerate(values, start=1)}
    lines = deck.splitlines(keepends=True)
    statements = [_statements(line) for line in lines]
    replacements: dict[int, str] = {}
    for name, value in values.items():
        apdl = apdl_names.get(name, name)
        safe = safe_names[name]
        value = float(value)
        if not math.isfinite(value):
            raise ValueError(f"parameter {name!r}: value {value} is not finite")
        name_pattern = re.escape(apdl)
        set_statement = re.compile(rf"\*SET\s*,\s*{name_pattern}\s*(,|$)", re.IGNORECASE)
        assignment = re.compile(rf"{name_pattern}\s*=", re.IGNORECASE)
        defining = re.compile(rf"({'|'.join(re.escape(c) for c in _DEFINING_COMMANDS)})\s*,\s*{name_pattern}\s*(,|\(|$)", re.IGNORECASE)
        hits = [number for number, parts in enumerate(statements) if any(set_statement.match(part) for part in parts)]
        if not hits:
            raise ValueError(f"APDL deck: parameter {name!r} has no '*SET,{apdl},<value>' line to substitute")
        if len(hits) > 1:
            raise ValueError(f"APDL deck: parameter {name!r} has {len(hits)} '*SET,{apdl},…' lines (lines {[h + 1 for h in hits]}); expected one")
        assigned = [number + 1 for number, parts in enumerate(statements) if any(assignment.match(part) for part in parts)]
        if assigned:
            raise ValueError(f"APDL deck: parameter {name!r} is also assigned with '{apdl} = …' on line(s) {assigned}; define it only by one *SET line")
        redefined = [(number + 1, m.group(1).upper()) for number, parts in enumerate(statements) for part in parts if (m := defining.match(part))]
        if redefined:
            raise ValueError(
                f"APDL deck: parameter {name!r} is also defined by {redefined[0][1]} on line(s) {[n for n, _ in redefined]}; "
                f"define it only by one *SET line"
            )
        number = hits[0]
        body = lines[number].rstrip("\r\n")
        ending = lines[number][len(body) :]
        match = re.fullmatch(rf"(\s*\*SET\s*,\s*)({name_pattern})(\s*,\s*)([^,!$]*?)(\s*)((?:!.*)?)", body, re.IGNORECASE | re.DOTALL)
        if match is None or len(statements[number]) > 1:
            raise ValueError(
                f"APDL deck, line {number + 1}: the *SET line of parameter {name!r} must hold one value, on a line of its own "
                f"(no further values, no '$' separators; a '!' comment is fine), got {body.strip()!r}"
            )
        prefix, deck_name, separator, _, spacing, comment = match.groups()
        replacements[number] = (
            f"{prefix}{safe}{separator}{value!r}   ! nlupdate parameter {_comment_text(name)}\n"
            f"{prefix}{deck_name}{separator}{safe}{spacing}{comment}{ending or ''}"
        )
    return "".join(replacements.get(number, line) for number, line in enumerate(lines))

def requested_point(node: NodeSpec, units: DeckUnits) -> tuple[float, float, float] | None:
    """The point (m) a node spec asks for: a point itself, a literal ``NODE(x,y,z)`` (deck
    units) converted to metres, else None (node numbers, other expressions)."""
    if isinstance(node, tuple):
        return node
    if isinstance(node, str):
        match = _NODE_POINT.fullmatch(node.strip())
        if match:
            return tuple(fortran_float(v) / units.per_metre for v in match.groups())  # type: ignore[return-value]
    return None

def single_expression(text: str) -> bool:
    """True when ``text`` can stand alone after ``NAME=``: no statement separator, comment,
    line break, or comma outside parentheses (which would assign several values)."""
    if any(ch in text for ch in "$!\r\n"):
        return False
    depth = 0
    for ch in text:
        depth += ch == "("
        depth -= ch == ")"
        if depth < 0 or (ch == "," and depth == 0):
            return False
    return depth == 0
