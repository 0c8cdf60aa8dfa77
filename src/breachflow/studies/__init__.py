"""Validation and stability studies built on the DEM and the fluid forces: the free-flight validation of
the fluid forces and the stone stability study."""
