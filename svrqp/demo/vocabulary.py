"""The one vocabulary of a reproduction row: *reproduced*, *same direction*, *differs*.

Every row that sets a paper's published number against ours — in ``results.json``, the terminal
table of ``svrqp demo``, its ``report.html`` and ``docs/reproduction.md`` — carries one of three
labels, given by one rule (:func:`label_for`):

* **reproduced** — ours lies within the row's stated tolerance of the paper's number, and the
  paper's comparison that the number belongs to (if any) holds;
* **same direction** — the paper's comparison holds, the numbers differ by more than the
  tolerance;
* **differs** — the paper's comparison does not hold (or the row has no comparison and the
  number is outside the tolerance); such a row always carries the measured reason.

A row whose number is outside its tolerance says why in its note as well.
"""

from __future__ import annotations

from enum import Enum
from typing import Any

from svrqp.exceptions import ProblemError


class Label(str, Enum):
    """The label of a reproduction row (its value is the word printed everywhere)."""

    REPRODUCED = "reproduced"
    SAME_DIRECTION = "same direction"
    DIFFERS = "differs"

    def __str__(self) -> str:
        return self.value


#: The rule behind each label, as printed under every table of rows.
RULE = {
    Label.REPRODUCED: "within the stated tolerance of the paper's number (and the paper's "
                      "comparison holds)",
    Label.SAME_DIRECTION: "the paper's comparison holds, the numbers differ by more than the "
                          "tolerance",
    Label.DIFFERS: "the paper's comparison does not hold, or a number without a comparison is "
                   "outside the tolerance; the measured reason is given",
}
LABELS = tuple(label.value for label in Label)
#: The default tolerance: a quarter of the paper's number (its last digits are not ours to match).
RELATIVE_TOLERANCE = 0.25
#: Columns of the table every place prints (the report and the docs add the note).
COLUMNS = ("seed", "quantity", "metric", "paper", "ours", "tolerance", "comparison holds",
           "reproduction")


def label_for(paper: float, ours: float, tolerance: float, comparison_holds: bool | None) -> Label:
    """The label of a row by :data:`RULE`.

    Parameters
    ----------
    paper, ours
        The published number and ours, in the row's units.
    tolerance
        How far ours may lie from the paper's number and still reproduce it (same units, >= 0).
    comparison_holds
        Whether the paper's comparison that the number belongs to holds on our data; ``None``
        when the number stands alone (a magnitude, not a comparison).
    """
    if not tolerance >= 0:
        raise ProblemError(f"tolerance must be >= 0, got {tolerance}")
    within = abs(ours - paper) <= tolerance
    if comparison_holds is None:
        return Label.REPRODUCED if within else Label.DIFFERS
    if not comparison_holds:
        return Label.DIFFERS
    return Label.REPRODUCED if within else Label.SAME_DIRECTION


def reproduction_row(seed: str, quantity: str, metric: str, paper: float, ours: float, *,
                     comparison_holds: bool | None, note: str = "",
                     tolerance: float | None = None) -> dict[str, Any]:
    """One row of the reproduction table, labelled by :func:`label_for`.

    ``tolerance`` defaults to :data:`RELATIVE_TOLERANCE` of ``|paper|``. A row labelled
    *differs* or *same direction* needs its ``note`` (the measured reason).

    Raises
    ------
    ProblemError
        A row that is not *reproduced* and has no note.
    """
    tolerance = RELATIVE_TOLERANCE * abs(paper) if tolerance is None else float(tolerance)
    label = label_for(paper, ours, tolerance, comparison_holds)
    if label is not Label.REPRODUCED and not note.strip():
        raise ProblemError(f"{seed} {quantity!r} is labelled {label.value!r} without its "
                           "measured reason (note)")
    return {"seed": seed, "quantity": quantity, "metric": metric, "paper": float(paper),
            "ours": float(ours), "tolerance": tolerance, "comparison_holds": comparison_holds,
            "reproduction": label.value, "note": note}


def cells(row: dict[str, Any]) -> list[str]:
    """The printed cells of a row, in :data:`COLUMNS` order (the same text everywhere)."""
    holds = {True: "yes", False: "no", None: "—"}[row["comparison_holds"]]
    return [row["seed"], row["quantity"], row["metric"], f"{row['paper']:.4g}",
            f"{row['ours']:.4g}", f"± {row['tolerance']:.2g}", holds, row["reproduction"]]


def markdown_table(rows: list[dict[str, Any]]) -> str:
    """The rows as the Markdown table of ``docs/reproduction.md`` (pipes escaped)."""
    lines = ["| " + " | ".join(COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for row in rows:
        lines.append("| " + " | ".join(cell.replace("|", "\\|") for cell in cells(row)) + " |")
    return "\n".join(lines) + "\n"


def rule_text() -> str:
    """The rule in one paragraph, for the foot of every table."""
    return "; ".join(f"{label.value}: {text}" for label, text in RULE.items()) + "."
