"""Where the tests find the repository's files."""

from pathlib import Path

#: The repository's root.
ROOT = Path(__file__).resolve().parents[1]
#: The example problems (examples/), with their layouts and plans.
EXAMPLES = ROOT / "examples"
#: The benchmark cases beside the repository (../shared/bench/cases).
CASES = ROOT.parent / "shared" / "bench" / "cases"
