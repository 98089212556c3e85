"""The command line: the only module that knows about the terminal and exit statuses."""

from __future__ import annotations

import sys

import click

from blockqc import __version__
from blockqc.errors import BlockqcError


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="blockqc")
def cli() -> None:
    """Inspect satellite image blocks adjusted without ground control points."""


def main(argv: list[str] | None = None) -> None:
    """Entry point: run the command group, turning blockqc's errors into messages and exit 2."""
    try:
        rc = cli.main(args=argv, prog_name="blockqc", standalone_mode=False)
    except BlockqcError as exc:
        for problem in exc.problems:
            click.echo(f"error: {problem}", err=True)
        sys.exit(exc.exit_code)
    except click.exceptions.Abort:
        click.echo("aborted", err=True)
        sys.exit(130)
    except click.ClickException as exc:
        exc.show()
        sys.exit(2)
    sys.exit(rc or 0)
