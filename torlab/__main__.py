"""``python -m torlab`` runs the command-line interface."""

from torlab.cli import run

if __name__ == "__main__":
    run()
