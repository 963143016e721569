"""`python -m pyvehtrack ...`: the pyvehtrack command."""
import sys

from pyvehtrack.cli import main

sys.exit(main())
