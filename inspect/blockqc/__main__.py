"""`python -m blockqc` runs the command line."""

from blockqc.cli import run

run()
