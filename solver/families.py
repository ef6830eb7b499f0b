"""The constraint families of the MIQP (paper Sec. 4-5), listed once.

The formulation builds each family with the function named `builder`
(`solver.miqp.formulation`), the independent checker verifies it under the report
kind `check` (`solver.verify.checker`, which shares no code with the MIQP), and the
table in docs/method.md is `markdown_table()`. Tests hold all three to this list, so
a family added here and missing elsewhere fails the suite (docs/architecture.md,
"Adding a constraint family").
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class ConstraintFamily:
    """One family of constraints: its symbol in the paper, the equation it cites, the
    formulation function that builds it, and the checker's report kind for it."""

    symbol: str
    equation: str
    builder: str
    #: The report kind the checker gives its verdicts under; None when the family only
    #: shapes the search and answers to another family's check.
    check: str | None
    meaning: str


#: Every family of a level's MIQP, in the paper's order (the order the model adds them).
FAMILIES: tuple[ConstraintFamily, ...] = (
    ConstraintFamily("C_inside", "Eq. 1", "c_inside", "inside",
                     "each rectangle inside the outline, clear of obstacles"),
    ConstraintFamily("C_overlap", "Eq. 2", "c_overlap", "overlap",
                     "no two rectangles overlap"),
    ConstraintFamily("C_size", "Eq. 5", "c_size", "size",
                     "width and depth within the room's minimum and maximum"),
    ConstraintFamily("C_ratio", "Eq. 7", "c_ratio", "aspect_ratio",
                     "long side over short side within the room's ratio range"),
    ConstraintFamily("C_pos", "Eq. 8", "c_pos", "position",
                     "the room covers each of its guide points"),
    ConstraintFamily("C_boundary", "Eq. 9", "c_boundary", "boundary",
                     "one side of the room on an exterior wall it asks for"),
    ConstraintFamily("C_adj", "Eq. 10-11", "c_adj", "adjacency",
                     "two rooms share a wall of at least the contact length"),
    ConstraintFamily("C_refine", "Eq. 13", "c_refine", None,
                     "the halves of a split room stay within delta of their parent"),
    ConstraintFamily("C_envelope", "Eq. 5, 7", "c_envelope", None,
                     "size and ratio on the bounding box of a room of several rectangles"),
)


def family(symbol: str) -> ConstraintFamily:
    """The family named `symbol` ("C_adj")."""
    for f in FAMILIES:
        if f.symbol == symbol:
            return f
    raise KeyError(symbol)


def markdown_table() -> str:
    """The families as the Markdown table docs/method.md shows."""
    rows = ["| family | equation | built by | checked as | what it asks |",
            "|---|---|---|---|---|"]
    rows += [f"| {f.symbol} | {f.equation} | `miqp.formulation.{f.builder}` | "
             f"{f'`{f.check}`' if f.check else '(through the others)'} | {f.meaning} |"
             for f in FAMILIES]
    return "\n".join(rows) + "\n"
