"""``python -m umbmark``: the same as the ``umbmark`` console script."""

from .cli import main

if __name__ == "__main__":
    main()
