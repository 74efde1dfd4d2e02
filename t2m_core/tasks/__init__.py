"""The language task suite (tasks.md): seven tasks shipped as YAML package data, their model and
a validating loader."""

from t2m_core.tasks.loader import (
    TaskFileError,
    TaskNotFoundError,
    list_tasks,
    load_task,
    load_task_file,
    parse_task,
    task_ids,
)
from t2m_core.tasks.model import TASK_PROPERTIES, Task

__all__ = [
    "TASK_PROPERTIES",
    "Task",
    "TaskFileError",
    "TaskNotFoundError",
    "list_tasks",
    "load_task",
    "load_task_file",
    "parse_task",
    "task_ids",
]
