"""Plan execution (paper: step B5): the PyBullet world, one executor per skill kind, OMPL navigation,
grasp/carry/release, workers walking the site, the lidar, and the run record written to disk.
"""
