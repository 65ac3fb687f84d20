"""The subcommands of the ``skthermal`` command, one module per group.

The parser is in :mod:`skthermal.cli`, which imports a module of this package
only when its subcommand runs, so that ``skthermal --help`` stays fast.
"""
