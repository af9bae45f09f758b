"""`python -m lutbake`: the same command line as the `lutbake` script."""

from lutbake.cli import main

main()
