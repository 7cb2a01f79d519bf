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
``__post_init__``: one place, whichever door the values came through. A key may take one
of several forms (``kind="choice|numbers"``: ``hold_out = "each"`` or a list of levels);
a study table may be declared by several classes, each naming its own fields
(:func:`settings_of` with ``own=True``: a subclass's fields without its base's).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Mapping

#: The forms a setting can take, as a reader would write them: ``path`` is a string naming a
#: file (the reader resolves it), ``table`` a table of options (``tables``: an array of them),
#: ``number_table`` a table of name = number, ``string_rows``/``number_rows`` a list of
#: non-empty lists. A union of forms joins them with ``|`` (tried in order).
KINDS = ("string", "strings", "choice", "integer", "integers", "number", "numbers", "boolean", "path", "table",
         "tables", "number_table", "string_rows", "number_rows")


class SettingError(ValueError):
    """A value that is not of its key's declared form: ``key``, the ``expected`` form, the value ``got``
    (``None`` when the key is missing)."""

    def __init__(self, key: str, expected: str, got: Any = None) -> None:
        self.key, self.expected, self.got = key, expected, got
        super().__init__(f"{key}: expected {expected}" + ("" if got is None else f", got {got!r}"))


@dataclass(frozen=True)
class Setting:
    """How one field is read, named and documented.

    kind: one of :data:`KINDS`, or several joined by ``|``; ``strings``/``numbers`` are
    lists (a comma-separated list on the command line). minimum/maximum: inclusive bounds of
    a number or integer (of each entry of ``numbers`` and ``number_table``); below_maximum:
    the maximum itself is excluded. length: the exact length of a list; min_length: its
    least length. choices: the allowed values of a ``choice``. form_text: the expected form
    in words, when the generated one would say less (a rule of the class). unit: the unit of
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
    min_length: int | None = None
    choices: tuple[str, ...] = ()
    form_text: str | None = None
    flag: str | None = None
    method: str | None = None
    required: bool = False

    def __post_init__(self) -> None:
        if any(kind not in KINDS for kind in self.kinds) or len(set(self.kinds)) != len(self.kinds):
            raise ValueError(f"setting kind {self.kind!r}: expected one or more of {KINDS} joined by '|'")
        if ("choice" in self.kinds) != bool(self.choices):
            raise ValueError("a choice setting, and only a choice, lists its choices")

    @property
    def kinds(self) -> tuple[str, ...]:
        """The forms the value may take, in the order they are tried."""
        return tuple(self.kind.split("|"))

    def form(self) -> str:
        """The expected form, as an error message and the docs table say it."""
        if self.form_text is not None:
            return self.form_text
        return " or ".join(self._form(kind) for kind in self.kinds)

    def _form(self, kind: str) -> str:
        if kind == "choice":
            return f"one of {list(self.choices)}"
        bounds = self._bounds()
        if kind in ("strings", "numbers", "integers"):
            size = f"{self.length} " if self.length is not None else ""
            empty = "non-empty " if self.length is None and self.min_length == 1 else ""
            least = f" (at least {self.min_length})" if self.length is None and (self.min_length or 0) > 1 else ""
            entries = f"{kind}{' ' + bounds if bounds and kind != 'strings' else ''}"
            return f"a {empty}list of {size}{entries}{least}"
        if kind in ("string_rows", "number_rows"):
            return f"a non-empty list of non-empty lists of {kind.split('_')[0]}s"
        if kind == "integer":
            return f"an integer{' ' + bounds if bounds else ''}"
        if kind == "number":
            return f"a number {bounds}" if bounds else "a finite number"
        if kind == "number_table":
            return f"a table of name = number{' ' + bounds if bounds else ''}"
        return {"boolean": "true or false", "path": "a file name (string)", "table": "a table",
                "tables": "an array of tables"}.get(kind, "a string")

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
        """The value in the field's type (the first of its kinds it is); ``ValueError`` (the
        expected form) when it is none."""
        wrong = ValueError(f"expected {self.form()}, got {value!r}")
        for kind in self.kinds:
            try:
                return self._parse(kind, value, wrong)
            except ValueError:
                continue
        raise wrong

    def _parse(self, kind: str, value: Any, wrong: ValueError) -> Any:
        if kind in ("string", "choice", "path"):
            if not isinstance(value, str) or kind == "choice" and value not in self.choices:
                raise wrong
            return value
        if kind == "boolean":
            if not isinstance(value, bool):
                raise wrong
            return value
        if kind == "tables":
            if not isinstance(value, (list, tuple)) or not all(isinstance(v, Mapping) for v in value):
                raise wrong
            return tuple(dict(v) for v in value)
        if kind in ("table", "number_table"):
            if not isinstance(value, Mapping):
                raise wrong
            return dict(value) if kind == "table" else {str(k): self._number(v, wrong) for k, v in value.items()}
        if kind in ("string_rows", "number_rows"):
            if not isinstance(value, (list, tuple)) or not value or any(not isinstance(row, (list, tuple)) or not row
                                                                        for row in value):
                raise wrong
            entry = "strings" if kind == "string_rows" else "numbers"
            return tuple(self._parse(entry, list(row), wrong) for row in value)
        if kind in ("strings", "numbers", "integers"):
            if (not isinstance(value, (list, tuple)) or self.length is not None and len(value) != self.length
                    or self.min_length is not None and len(value) < self.min_length):
                raise wrong
            if kind == "numbers":
                return tuple(self._number(v, wrong) for v in value)
            if kind == "integers":
                return tuple(self._parse("integer", v, wrong) for v in value)
            if not all(isinstance(v, str) for v in value):
                raise wrong
            return tuple(value)
        if kind == "integer":
            if isinstance(value, bool) or not isinstance(value, int) or not self._in_bounds(value):
                raise wrong
            return value
        return self._number(value, wrong)

    def _number(self, value: Any, wrong: ValueError) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not self._in_bounds(float(value)):
            raise wrong
        return float(value)


def setting(default: Any = dataclasses.MISSING, *, default_factory: Any = dataclasses.MISSING,
            **declaration: Any) -> Any:
    """A dataclass field declared with its :class:`Setting` (keyword arguments); a mutable
    default (a table) is given by ``default_factory``."""
    return dataclasses.field(default=default, default_factory=default_factory,
                             metadata={"setting": Setting(**declaration)})


def settings_of(cls: type, own: bool = False) -> dict[str, tuple[dataclasses.Field, Setting]]:
    """Field name → (field, its :class:`Setting`) of a settings class, in declaration order;
    with ``own``, only the fields the class itself declares (not those of its bases)."""
    mine = set(vars(cls).get("__annotations__", {})) if own else None
    found = {f.name: (f, f.metadata["setting"]) for f in dataclasses.fields(cls)
             if "setting" in f.metadata and (mine is None or f.name in mine)}
    if not found:
        raise TypeError(f"{cls.__name__} declares no settings")
    return found


def parse_mapping(declared: Mapping[str, tuple[dataclasses.Field, Setting]], mapping: Mapping[str, Any]) -> dict[str, Any]:
    """The values of the keys given in ``mapping``, each parsed by its declaration (keys left
    out are left out: the class's default applies).

    Raises :class:`SettingError` for an unknown key (expected: one of the declared keys),
    a missing required key or a value not of its key's form."""
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
    return values


def from_mapping(cls: type, mapping: Mapping[str, Any]) -> Any:
    """An instance of ``cls`` from a mapping of its keys (a study table).

    Raises :class:`SettingError` as :func:`parse_mapping` does, and ``ValueError`` for the
    class's own rules."""
    return cls(**parse_mapping(settings_of(cls), mapping))


def default_text(field: dataclasses.Field, declaration: Setting) -> str:
    """The default as the docs say it."""
    if declaration.default_text is not None:
        return declaration.default_text
    if declaration.required or field.default is dataclasses.MISSING and field.default_factory is dataclasses.MISSING:
        return "—"
    value = field.default if field.default is not dataclasses.MISSING else field.default_factory()
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, str):
        return f'`"{value}"`'
    if isinstance(value, tuple):
        return f"`{list(value)}`"
    return f"`{value}`"


def docs_table(*declared: type | Mapping[str, tuple[dataclasses.Field, Setting]]) -> str:
    """The markdown table of the keys of one or more settings classes (or of
    :func:`settings_of` selections), in order: key, form, unit, default, meaning."""
    def cell(text: str) -> str:
        return text.replace("|", "\\|")

    rows = ["| key | form | unit | default | meaning |", "|---|---|---|---|---|"]
    fields: dict[str, tuple[dataclasses.Field, Setting]] = {}
    for part in declared:
        fields.update(settings_of(part) if isinstance(part, type) else part)
    for name, (field, declaration) in fields.items():
        form = (" or ".join(f'`"{c}"`' for c in declaration.choices)
                if declaration.kind == "choice" and declaration.form_text is None
                else declaration.form()) + (", **required**" if declaration.required else "")
        meaning = declaration.meaning + (f" ({declaration.method.upper()} only)" if declaration.method else "")
        rows.append(f"| `{name}` | {cell(form)} | {cell(declaration.unit)} | {cell(default_text(field, declaration))} "
                    f"| {cell(meaning)} |")
    return "\n".join(rows)
