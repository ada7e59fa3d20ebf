"""``python -m bubblerob_env.core``: compile every numba kernel now (a command shim).

The command is :mod:`bubblerob_cli.warmup`.
"""

from bubblerob_cli.warmup import main

if __name__ == "__main__":
    main()
