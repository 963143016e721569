"""`python -m pyvehtrack.cli ...`: the pyvehtrack command."""
import sys

from pyvehtrack.cli import main

sys.exit(main())
