"""The construction robot knowledge base (paper: Figure 1's middle system, steps A1-A5 and B3).

Skills, task specifications and robots in OWL/RDF (``ontology/``); A1-A2 robotized task to task
specification to actions, skills and bindings; A3 the bindings turned into SHACL shapes whose
violations are the additional modeling requirements; A4 validation of the augmented model; A5
jobsite restrictions and skill parameters; B3 robot selection with reasons. It knows no building
file: it reads graphs. Imports only :mod:`kbplanner.core`.
"""
