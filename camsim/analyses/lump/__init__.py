"""Lumped-parameter reduction: from a designer's parts file to a camsim machine file."""
