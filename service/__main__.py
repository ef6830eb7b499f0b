"""`python -m floorplan.service ...` is the `floorplan` command."""

import sys

from floorplan.service.cli import main

sys.exit(main())
