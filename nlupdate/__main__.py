"""``python -m nlupdate`` runs the command-line interface."""
import sys

from nlupdate.cli import main

sys.exit(main())
