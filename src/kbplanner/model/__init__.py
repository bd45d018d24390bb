"""The 4D BIM environment (paper: Figure 1's left system): the building model and its schedule.

IFC import (IFC2X3/IFC4/IFC4X3, units, geometry, semantics) into the model graph, the construction
schedule (CSV or the IFC's work schedule) with element states at a date, and the project directory
(``project.toml``: model, schedule, site, jobsite, scenarios) loaded as
:class:`~kbplanner.model.project_data.ProjectData`, which binds a building to the knowledge base.
Imports :mod:`kbplanner.core` and :mod:`kbplanner.knowledge` (to load the knowledge base).
"""
