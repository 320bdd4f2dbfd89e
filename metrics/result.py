"""Result: the base of the typed metric results, one small frozen dataclass per metric family."""
from __future__ import annotations

from dataclasses import fields

__all__ = ["Result", "keys_of"]


class Result:
    """Mixin for a frozen dataclass whose field names are the keys it reports."""

    def as_dict(self) -> dict:
        """The flat dict of the fields, in field order; a `note` of None is left out."""
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == "note" and value is None:
                continue
            out[f.name] = value
        return out


def keys_of(result_type: type) -> tuple[str, ...]:
    """The keys a Result dataclass reports (its field names)."""
    return tuple(f.name for f in fields(result_type))
