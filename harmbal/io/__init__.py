"""Stage 6, files: netCDF archives of analysis trees and atomic writes."""
