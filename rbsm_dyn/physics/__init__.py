"""Numba kernels (DESIGN.md §3): nothing here imports case, mesh or io.

Their on-disk cache: rbsm_dyn/_kernel_cache.py (set on the package's import).
"""
