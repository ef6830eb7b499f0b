"""``python -m solver``: the `floorplan` command (see `solver.cli`)."""

from solver.cli import main

raise SystemExit(main())
