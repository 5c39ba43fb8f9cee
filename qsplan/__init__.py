"""The application layer: the ``qsplan`` command line, its subcommands and the HTML report.

The only layer that may import everything (planner, sim, scenarios).
"""
