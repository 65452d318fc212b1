"""``python -m exotune`` runs the command line (SPEC §8)."""

from exotune.cli import main

if __name__ == "__main__":
    main()
