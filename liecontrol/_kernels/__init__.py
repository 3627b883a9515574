"""Compiled scalar kernels: the one implementation of each per-step formula.

Each kernel works on one element (a 3-vector, a 3×3 matrix, one spacecraft) in the
numba-compatible subset of Python and is compiled by :func:`liecontrol._jit.njit` (plain Python
without numba). The public numpy API validates its input and then calls these kernels over the
batch; the simulator's fused loop calls them directly. Kernels never validate.
"""
