"""Model assembly: from a machine description to the linear branch systems the engine steps."""
