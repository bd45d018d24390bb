"""Analysis of simulated runs (paper: Section 4's results): durations per action/element/task,
human-robot proximity, fit into the schedule, scenario comparison, plots and the HTML report.
"""
