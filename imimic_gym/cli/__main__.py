"""`python -m imimic_gym.cli` runs the `imimic` command."""

import sys

from imimic_gym.cli import main

sys.exit(main())
