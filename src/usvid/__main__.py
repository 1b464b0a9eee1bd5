"""``python -m usvid``: the command-line interface (:mod:`usvid.cli`)."""

from usvid.cli import main

if __name__ == "__main__":
    main()
