"""Foundation of every step: errors, package resources, RDF input/output, the vocabulary, IRIs, named
SPARQL queries, graph stores (rdflib, Oxigraph, endpoints), tables and atomic output files.

Nothing here knows a building, a robot or a step of the paper; every other subpackage may import it.
"""
