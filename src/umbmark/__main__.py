"""``python -m umbmark``: the same as the ``umbmark`` console script."""

from umbmark.cli import main

if __name__ == "__main__":
    main()
