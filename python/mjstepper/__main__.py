"""The mjstepper command (`mjstepper ...` or `python -m mjstepper ...`): the C++ command itself,
from the package's engine (README, "The command")."""
import sys


def main():
    from . import _engine  # the package's __init__ has set the engine's paths
    sys.stdout.flush()
    return _engine.main(["mjstepper", *sys.argv[1:]])


if __name__ == "__main__":
    sys.exit(main())
