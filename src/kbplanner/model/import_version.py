"""The IFC importer's version (4D model import): one constant, light, read by the project loader to key
its import cache without loading ifcopenshell (:mod:`kbplanner.model.ifc_import` re-exports it)."""

# Bump when the graph or meshes written for the same IFC change (the project loader caches imports).
IMPORTER_VERSION = "3"
