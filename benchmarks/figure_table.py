"""The two-column "figure | value" table the language benchmarks print (llm_goals.py, llm_quality.py)."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from rich.console import Console
from rich.table import Table


def print_figure_table(title: str, figures: Mapping[str, Any], digits: Mapping[str, int] | None = None) -> None:
    """Print ``figures`` as rows, floats with ``digits[key]`` decimals (3 by default), others as text."""
    table = Table(title=title, title_justify="left")
    table.add_column("figure")
    table.add_column("value", justify="right")
    for key, value in figures.items():
        table.add_row(key, f"{value:.{(digits or {}).get(key, 3)}f}" if isinstance(value, float) else str(value))
    Console().print(table)
