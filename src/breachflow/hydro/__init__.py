"""Hydrodynamic solves around the breach: the solver registry (the embedded shallow-water solver of
:mod:`breachflow.swe`, or ingested snapshots served unchanged), the local model nested in an ingested
regional field, and the warm re-solve of a region around the cells a closure cycle changed."""
