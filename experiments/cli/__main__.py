"""`python -m experiments.cli`: the iblcheck command line."""

import sys

from experiments.cli.entry import main

sys.exit(main())
