"""Reading and writing files: atomic output, HDF5 results, CSV."""
