"""``python -m bubblerob_env.mjwarp [cpu|cuda:0]``: compile the Warp kernels (a command shim).

The command is :mod:`bubblerob_cli.warp_kernels`.
"""

from bubblerob_cli.warp_kernels import main

if __name__ == "__main__":
    main()
