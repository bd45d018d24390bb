"""Beyond one case study: generated buildings, parameter sweeps over layouts and seeds (locally or
on Dask/Ray), and every robotized task of a whole building simulated in parallel processes.
"""
