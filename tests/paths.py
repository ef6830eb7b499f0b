"""Where the tests find the repository's files."""

from pathlib import Path

#: The repository's root.
ROOT = Path(__file__).resolve().parents[1]
#: The example problems (examples/), with their layouts and plans.
EXAMPLES = ROOT / "examples"
#: The benchmark cases (bench/data/cases): the paper's Table 1 rows.
CASES = ROOT / "bench" / "data" / "cases"
#: The planted briefs drawn with their plans (bench/data/planted, and rooms of several
#: rectangles in bench/data/planted-complex).
PLANTED = ROOT / "bench" / "data" / "planted"
PLANTED_COMPLEX = ROOT / "bench" / "data" / "planted-complex"
