"""`python -m experiments.cli`: the iblcheck command line."""

import sys

from experiments.cli.main import main

sys.exit(main())
