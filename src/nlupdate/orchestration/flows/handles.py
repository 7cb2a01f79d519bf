"""Values handed to flows by reference: :class:`Handle`.

The Prefect API stores a flow run's parameters as JSON (at most 512 KB); a handle's JSON is
its one-line ``description``, which is what the run's page shows, while the flow gets
:attr:`Handle.value` itself. The value is a private attribute, so Prefect does not walk
through it looking for futures (seconds for a sweep's results).
"""
from __future__ import annotations

from typing import Any

from pydantic import BaseModel, ConfigDict, PrivateAttr, model_serializer

from nlupdate.study.spec import Study


class Handle(BaseModel):
    """A value and its one-line description (see the module docstring)."""

    model_config = ConfigDict(frozen=True)
    description: str
    _value: Any = PrivateAttr()

    @property
    def value(self) -> Any:
        return self._value

    @model_serializer
    def _as_description(self) -> str:
        return self.description


def handle(value: Any, description: str) -> Handle:
    wrapped = Handle(description=description)
    wrapped._value = value
    return wrapped


def study_handle(study: Study) -> Handle:
    """The study, as its run pages show it: name, file and hash."""
    return handle(study, f"study {study.name!r} ({study.path}, sha256 {study.sha256[:12]})")
