"""The robot of the simulation environment: URDF models, arm inverse kinematics (closed form and
numeric), base footprint and the lidar sensor. Used by planning (B4) and simulation (B5).
"""
