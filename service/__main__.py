"""`python -m service ...` is the `floorplan` command."""

import sys

from service.cli import main

sys.exit(main())
