"""The ``project.toml`` sections that a generated building (``generate-building``) and a proposed project
(``kbplanner init``) share: model files, working calendar, simulated task (scale step: writing projects)."""

from __future__ import annotations


def model_calendar_simulation(ifc: str, augmentation: str, task: str, sim_date: str) -> list[str]:
    """The ``[model]``, ``[calendar]`` and ``[simulation]`` sections; ``augmentation`` is the TOML value
    written after ``augmentation =`` (a list, maybe with a comment)."""
    return [
        "[model]",
        f'ifc = "{ifc}"',
        'schedule = "schedule.csv"',
        'site = ["site/site_layout.ttl", "site/workers.ttl"]',
        'jobsite = ["site/jobsite.ttl"]',
        f"augmentation = {augmentation}",
        "",
        "[calendar]",
        'work_start = "07:00"',
        'work_end = "15:30"',
        'workdays = ["Mon", "Tue", "Wed", "Thu", "Fri"]',
        "",
        "[simulation]",
        f'task = "{task}"',
        f'date = "{sim_date}"',
        "",
    ]
