"""``python -m adavar.cli``."""

# the package's run(): a worker process that imports this module (as the parent's main
# module) then does not import the command line
from adavar.cli import run

if __name__ == "__main__":  # not when a worker process imports it
    run()
