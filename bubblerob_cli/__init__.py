"""Every ``bubblerob`` command: argument parsing, printing, exit codes and Ray orchestration.

The application on top of the libraries (``train`` -> ``policies`` -> ``bubblerob_env``): it
imports them, and nothing imports it (docs/ARCHITECTURE.md; ``tests/test_layers.py`` holds the
rule). ``bubblerob`` is :func:`bubblerob_cli.main.main`.
"""
