"""`python -m lutbake.cli`: the command line."""

from lutbake.cli import main

main()
