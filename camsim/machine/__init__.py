"""The machine description: the machine file's schema, its validation and loading into SI dataclasses, overrides."""
