"""Task planning (paper: steps B1-B4): skill inputs by SPARQL from the bindings, element order, the
action-level plan with its robot, and arm/base poses plus carry modes refined by inverse kinematics.
"""
