"""``python -m problems`` and the console script ``anthropoid-planner``: see problems.cli."""

from __future__ import annotations

import sys
from collections.abc import Sequence

from problems import cli


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the exit status (0 ok, 1 failure, 2 bad input)."""
    return cli.main(argv)


if __name__ == "__main__":
    sys.exit(main())
