"""The package version (all steps): one place, read by the CLI, outputs and markers."""

__version__ = "0.1.0"
