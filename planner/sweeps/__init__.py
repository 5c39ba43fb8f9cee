"""Large sweeps on local processes or a Dask cluster, and seeded random systems.
"""
