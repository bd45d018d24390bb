"""The simulation world (paper: step A6, the start of Figure 1's right system).

The 4D model at a date becomes a world: built elements static, the task's elements at their storage,
later ones absent; occupancy maps per storey, robot footprints on them, and SDF/glTF/map exports.
"""
