"""Subcommands of `mkctl` for this area (being written; registers nothing yet)."""


def register(subparsers) -> None:
    """Add this module's subcommands to the `mkctl` parser."""
