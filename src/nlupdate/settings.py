"""One declaration per setting: the schema every front door reads.

A settings class is a frozen dataclass whose fields are declared with :func:`setting`:
the field's default, its form (type, bounds, choices, length), unit, the wording of its
default and its meaning. From that one declaration

* the study reader checks a TOML table (:func:`from_mapping`: one line naming the key and
  the expected form for a mistake),
* the command line gets its options (``nlupdate.app.cli.settings_options``: one option per
  field, named by ``flag`` or after the field),
* the Python API takes the fields as keyword arguments, and
* docs/study-files.md gets the table of keys (:func:`docs_table`; a test compares them).

Cross-field rules (a key that applies to one method only) stay in the class's
``__post_init__``: one place, whichever door the values came through.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

#: The forms a setting can take, as a reader would write them.
KINDS = ("string", "strings", "choice", "integer", "number", "numbers", "boolean")


class SettingError(ValueError):
    """A value that is not of its key's declared form: ``key``, the ``expected`` form, the value ``got``
    (``None`` when the key is missing)."""

    def __init__(self, key: str, expected: str, got: Any = None) -> None:
        self.key, self.expected, self.got = key, expected, got
        super().__init__(f"{key}: expected {expected}" + ("" if got is None else f", got {got!r}"))


@dataclass(frozen=True)
class Setting:
    """How one field is read, named and documented.

    kind: one of :data:`KINDS`; ``strings``/``numbers`` are lists (a comma-separated list
    on the command line). minimum/maximum: inclusive bounds of a number or integer (of each
    entry of ``numbers``); below_maximum: the maximum itself is excluded. length: the
    exact length of a list. choices: the allowed values of a ``choice``. unit: the unit of
    the value ("—" when it has none). default_text: the default as the docs word it (the
    field's own default otherwise). meaning: one sentence or more for the docs table and
    the option's help. flag: the command-line option (default ``--field-name``); ``""``
    keeps the field off the command line. method: the method the key applies to
    (documented; the class checks it). required: the key must be given.
    """

    kind: str
    meaning: str
    unit: str = "—"
    default_text: str | None = None
    minimum: float | None = None
    maximum: float | None = None
    below_maximum: bool = False
    above_minimum: bool = False
    length: int | None = None
    choices: tuple[str, ...] = ()
    flag: str | None = None
    method: str | None = None
    required: bool = False

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"setting kind {self.kind!r}: expected one of {KINDS}")
        if (self.kind == "choice") != bool(self.choices):
            raise ValueError("a choice setting, and only a choice, lists its choices")

    def form(self) -> str:
        """The expected form, as an error message and the docs table say it."""
        if self.kind == "choice":
            return " | ".join(f'"{c}"' for c in self.choices)
        bounds = self._bounds()
        if self.kind in ("strings", "numbers"):
            entry = "strings" if self.kind == "strings" else "numbers"
            size = f"{self.length} " if self.length is not None else ""
            return f"a list of {size}{entry}{' ' + bounds if bounds else ''}"
        if self.kind in ("integer", "number"):
            return f"{'an integer' if self.kind == 'integer' else 'a number'}{' ' + bounds if bounds else ''}"
        return "true or false" if self.kind == "boolean" else "a string"

    def _bounds(self) -> str:
        low, high = self.minimum, self.maximum
        if low is not None and high is not None:
            return f"in {'(' if self.above_minimum else '['}{low:g}, {high:g}{')' if self.below_maximum else ']'}"
        if low is not None:
            return f"{'>' if self.above_minimum else '≥'} {low:g}"
        if high is not None:
            return f"{'<' if self.below_maximum else '≤'} {high:g}"
        return ""

    def _in_bounds(self, value: float) -> bool:
        if not math.isfinite(value):
            return False
        if self.minimum is not None and (value < self.minimum or self.above_minimum and value == self.minimum):
            return False
        return self.maximum is None or not (value > self.maximum or self.below_maximum and value == self.maximum)

    def parse(self, value: Any) -> Any:
        """The value in the field's type; ``ValueError`` (the expected form) when it is not one."""
        wrong = ValueError(f"expected {self.form()}, got {value!r}")
        if self.kind in ("string", "choice"):
            if not isinstance(value, str) or self.kind == "choice" and value not in self.choices:
                raise wrong
            return value
        if self.kind == "boolean":
            if not isinstance(value, bool):
                raise wrong
            return value
        if self.kind == "strings":
            if not isinstance(value, (list, tuple)) or not all(isinstance(v, str) for v in value):
                raise wrong
            if self.length is not None and len(value) != self.length:
                raise wrong
            return tuple(value)
        if self.kind == "numbers":
            if not isinstance(value, (list, tuple)) or self.length is not None and len(value) != self.length:
                raise wrong
            return tuple(self._number(v, wrong) for v in value)
        if self.kind == "integer":
            if isinstance(value, bool) or not isinstance(value, int) or not self._in_bounds(value):
                raise wrong
            return value
        return self._number(value, wrong)

    def _number(self, value: Any, wrong: ValueError) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not self._in_bounds(float(value)):
            raise wrong
        return float(value)


def setting(default: Any = dataclasses.MISSING, **declaration: Any) -> Any:
    """A dataclass field declared with its :class:`Setting` (keyword arguments)."""
    return dataclasses.field(default=default, metadata={"setting": Setting(**declaration)})


def settings_of(cls: type) -> dict[str, tuple[dataclasses.Field, Setting]]:
    """Field name → (field, its :class:`Setting`) of a settings class, in declaration order."""
    found = {f.name: (f, f.metadata["setting"]) for f in dataclasses.fields(cls) if "setting" in f.metadata}
    if not found:
        raise TypeError(f"{cls.__name__} declares no settings")
    return found


def from_mapping(cls: type, mapping: Mapping[str, Any]) -> Any:
    """An instance of ``cls`` from a mapping of its keys (a study table).

    Raises :class:`SettingError` for an unknown key (expected: one of the declared keys),
    a missing required key or a value not of its key's form, and ``ValueError`` for the
    class's own rules."""
    declared = settings_of(cls)
    for key in mapping:
        if key not in declared:
            raise SettingError(key, f"one of the keys {', '.join(declared)}")
    values = {}
    for name, (_, declaration) in declared.items():
        if name not in mapping:
            if declaration.required:
                raise SettingError(name, f"{declaration.form()} (required)")
            continue
        try:
            values[name] = declaration.parse(mapping[name])
        except ValueError:
            raise SettingError(name, declaration.form(), mapping[name]) from None
    return cls(**values)


def default_text(field: dataclasses.Field, declaration: Setting) -> str:
    """The default as the docs say it."""
    if declaration.default_text is not None:
        return declaration.default_text
    if declaration.required or field.default is dataclasses.MISSING:
        return "—"
    value = field.default
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, tuple):
        return f"`{list(value)}`"
    return f"`{value}`"


def docs_table(cls: type) -> str:
    """The markdown table of the keys of ``cls``: key, form, unit, default, meaning."""
    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    rows = ["| key | form | unit | default | meaning |", "|---|---|---|---|---|"]
    for name, (field, declaration) in settings_of(cls).items():
        form = (" or ".join(f'`"{c}"`' for c in declaration.choices) if declaration.kind == "choice"
                else declaration.form()) + (", **required**" if declaration.required else "")
        meaning = declaration.meaning + (f" ({declaration.method.upper()} only)" if declaration.method else "")
        rows.append(f"| `{name}` | {cell(form)} | {cell(declaration.unit)} | {cell(default_text(field, declaration))} "
                    f"| {cell(meaning)} |")
    return "\n".join(rows)
