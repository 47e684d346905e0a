"""``python -m mkctl`` runs the command line."""
import sys

from .cli import main

# guarded: Dask's worker processes start by importing the main module again
if __name__ == "__main__":
    sys.exit(main())
