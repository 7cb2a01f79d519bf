"""``python -m nlupdate`` runs the command-line interface."""
import sys

from nlupdate.app.cli import main

sys.exit(main())
