"""Identified against true parameters: the table every report prints."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Mapping, Optional

from .solve import IdentificationResult

__all__ = ["ParameterComparison", "compare", "format_table"]


@dataclass(frozen=True)
class ParameterComparison:
    name: str
    true: Optional[float]
    identified: float
    std_error: float

    @property
    def rel_error(self) -> Optional[float]:
        """``(identified - true) / |true|``; None when the truth is unknown or zero."""
        if self.true is None or self.true == 0:
            return None
        return (self.identified - self.true) / abs(self.true)

    def as_json(self) -> dict:
        return {"true": self.true, "identified": self.identified, "rel_error": self.rel_error,
                "std_error": self.std_error}


def compare(result: IdentificationResult, truth: Mapping[str, float]) -> tuple[ParameterComparison, ...]:
    """One row per identified parameter; ``truth`` may lack some (then ``true`` is None)."""
    return tuple(ParameterComparison(n, truth.get(n), float(v), float(s))
                 for n, v, s in zip(result.names, result.values, result.std_errors))


def _fmt(x: Optional[float], spec: str) -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, spec)


def format_table(rows: tuple[ParameterComparison, ...], *, markdown: bool = False) -> str:
    head = ("parameter", "true", "identified", "rel. error", "std. error")
    body = [(r.name, _fmt(r.true, ".10g"), _fmt(r.identified, ".10g"), _fmt(r.rel_error, "+.2e"),
             _fmt(r.std_error, ".2e")) for r in rows]
    if markdown:
        lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(b) + " |" for b in body]
        return "\n".join(lines)
    widths = [max(len(x) for x in col) for col in zip(head, *body)]
    fmt = lambda cells: "  ".join(c.ljust(w) if i == 0 else c.rjust(w)  # noqa: E731
                                  for i, (c, w) in enumerate(zip(cells, widths)))
    return "\n".join([fmt(head), fmt(tuple("-" * w for w in widths))] + [fmt(b) for b in body])
