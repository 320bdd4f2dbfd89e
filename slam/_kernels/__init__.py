"""Numba kernels shared by the SLAM algorithms, each with a plain-numpy reference.

insert: log-odds ray insertion; interp: bilinear occupancy value and gradient (Hector);
gn_step: Gauss-Newton normal equations of scan-to-map matching.
"""
