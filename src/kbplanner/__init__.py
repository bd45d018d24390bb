"""kbplanner: plan and simulate construction robot work inside a 4D BIM model.

The pipeline follows the information flow of Oyediran et al. (A1-A6, B1-B5): an IFC model and its
schedule become an RDF graph; a construction robot knowledge base derives the additional modeling
requirements (SHACL) and the skill inputs (SPARQL); a PyBullet executor runs the plan.
See ``docs/architecture.md`` for where each step lives.
"""

from kbplanner.errors import KbplannerError

__version__ = "0.1.0"

__all__ = ["KbplannerError", "__version__"]
