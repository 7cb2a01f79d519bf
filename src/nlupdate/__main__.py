"""``python -m nlupdate`` runs the command-line interface."""
from nlupdate.app.cli import entry

entry()
