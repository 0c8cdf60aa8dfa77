"""``python -m breachflow``: the same program as the ``breachflow`` command."""
from .cli import main

if __name__ == "__main__":
    main()
