"""The ``t2m`` command line (typer). Progress and logs go to stderr; ``--json`` data to stdout."""
