"""Numba kernels shared by the SLAM algorithms, each with a plain-numpy reference.

insert: log-odds ray insertion; interp: bilinear occupancy value and gradient (Hector);
gauss_newton: Gauss-Newton normal equations and steps of scan-to-map matching (gn, pf);
smooth: range smoothing over neighbouring beams; censor: the shortfall the range limit leaves
on the hits near it; prob: log-odds to probability.
"""
