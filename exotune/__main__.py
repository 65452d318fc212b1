"""``python -m exotune`` runs the command line (docs/cli.md)."""

from exotune.cli import main

if __name__ == "__main__":
    main()
