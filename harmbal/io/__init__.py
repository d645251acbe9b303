"""The files stage: netCDF and Zarr archives of analysis trees, their integrity checks, atomic writes."""
