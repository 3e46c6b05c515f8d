"""``python -m coexist`` runs the command line."""

from coexist.cli.main import main

if __name__ == "__main__":
    main()
