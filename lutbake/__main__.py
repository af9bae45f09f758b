"""`python -m lutbake`: the same command line as the `lutbake` script."""

from .cli import main

main()
