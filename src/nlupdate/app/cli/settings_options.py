"""Command-line options made from a settings class's declaration (:mod:`nlupdate.settings`).

One option per declared field: ``--field-name`` unless the declaration names its ``flag``;
lists are comma-separated; a boolean is a switch. Values are checked by the declaration as
the options are parsed (argparse's one line, before any work). An option left out is not
passed on, so the settings class's own default applies — the one the study file and the
Python API get. Messages of the class's own rules name the options, not the fields
(:func:`with_flags`).
"""
from __future__ import annotations

import argparse
import re
from typing import Any, Callable, Iterable

from nlupdate.settings import Setting, default_text, settings_of


def flag_of(name: str, declaration: Setting) -> str:
    """The option of a field: its declared flag, or ``--`` and the name with dashes."""
    return declaration.flag or "--" + name.replace("_", "-")


def add_setting_options(parser: argparse.ArgumentParser, cls: type, skip: Iterable[str] = ()) -> None:
    """An option for every declared field of ``cls`` except ``skip`` and those declared off the CLI."""
    for name, (field, declaration) in settings_of(cls).items():
        if name in skip or declaration.flag == "":
            continue
        unit = "" if declaration.unit == "—" else f" [{declaration.unit}]"
        method = f"{declaration.method.upper()}: " if declaration.method else ""
        default = default_text(field, declaration).replace("`", "")
        help_text = f"{method}{declaration.meaning}{unit} (default: {default})".replace("%", "%%")
        options: dict[str, Any] = {"dest": name, "default": None, "help": help_text}
        if {"table", "tables", "number_table", "string_rows", "number_rows"} & set(declaration.kinds):
            raise TypeError(f"{cls.__name__}.{name}: a table has no command-line option (declare flag=\"\")")
        if declaration.kind == "boolean":
            options.update(action="store_const", const=True)
        elif declaration.kind == "choice" or declaration.kind == "choice|boolean":  # true/false: a study file's form
            options["choices"] = declaration.choices
        else:
            options["type"] = _parser(declaration)
            options["metavar"] = {"strings": "A,B", "numbers": "X,Y", "integer": "N", "path": "FILE"}.get(
                declaration.kind, "VALUE")
        parser.add_argument(flag_of(name, declaration), **options)


def setting_values(args: argparse.Namespace, cls: type, skip: Iterable[str] = ()) -> dict[str, Any]:
    """The fields the user gave on the command line (already checked by their declaration)."""
    return {name: getattr(args, name) for name, (_, declaration) in settings_of(cls).items()
            if name not in skip and declaration.flag != "" and getattr(args, name, None) is not None}


def with_flags(message: str, cls: type) -> str:
    """A message of the class's own rules with each field name replaced by its option (the
    names with an underscore: one-word names such as ``method`` are also plain words)."""
    for name, (_, declaration) in settings_of(cls).items():
        if declaration.flag != "" and "_" in name:
            message = re.sub(rf"\b{name}\b", flag_of(name, declaration), message)
    return message


def _value(kind: str, text: str) -> Any:
    """The text of an option as the value of one form (``ValueError`` when it is not one)."""
    if kind in ("strings", "numbers"):
        items = [item.strip() for item in text.split(",") if item.strip()]
        return items if kind == "strings" else [float(item) for item in items]
    if kind == "integer":
        return int(text)
    if kind == "number":
        return float(text)
    return text


def _parser(declaration: Setting) -> Callable[[str], Any]:
    """The option's converter: the first of the declared forms the text is (a union such as
    ``choice|numbers`` takes ``top`` or ``0.5,1``)."""
    def parse(text: str) -> Any:
        for kind in declaration.kinds:
            try:
                return declaration.parse(_value(kind, text))
            except ValueError:
                continue
        form = declaration.form().replace("a list of", "comma-separated").replace("a non-empty list of",
                                                                                   "comma-separated")
        raise argparse.ArgumentTypeError(f"expected {form}, got {text!r}")
    return parse
