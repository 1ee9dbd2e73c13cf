"""``python -m torlab`` runs the command-line interface."""

from torlab.cli import main

if __name__ == "__main__":
    raise SystemExit(main())
