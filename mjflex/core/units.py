"""Unit conversions for stiffness and damping from the literature: multiply to get SI, divide to get back.

mjflex works in SI (N m/rad, N/m, N m s/rad, N s/m). Papers and data sheets give N m/deg and N/mm;
each name below is the SI value of one such unit, so ``2.5 * units.N_m_per_deg`` is 2.5 N m/deg in
N m/rad, and ``K[0] / units.N_m_per_deg`` reads a stiffness back in N m/deg.

* angles and lengths: ``rad``, ``deg``; ``m``, ``cm``, ``mm``
* rotational stiffness: ``N_m_per_rad``, ``N_m_per_deg``, ``N_mm_per_rad``, ``N_mm_per_deg``
* translational stiffness: ``N_per_m``, ``N_per_mm``, ``N_per_um``
* rotational damping: ``N_m_s_per_rad``, ``N_m_s_per_deg``; translational damping: ``N_s_per_m``, ``N_s_per_mm``

Examples
--------
A lumbar disc from the literature (rotations in N m/deg, translations in N/mm), and its damping:

>>> from mjflex import units
>>> K = [2.0 * units.N_m_per_deg] * 3 + [500 * units.N_per_mm] * 3
>>> print([round(k, 1) for k in K])
[114.6, 114.6, 114.6, 500000.0, 500000.0, 500000.0]
>>> print(f"{0.02 * units.N_m_s_per_deg:.3f} N m s/rad, {0.3 * units.N_s_per_mm:.0f} N s/m")
1.146 N m s/rad, 300 N s/m
>>> print(f"{K[0] / units.N_m_per_deg:.2f} N m/deg; a range of 10.7 deg is {10.7 * units.deg:.4f} rad")
2.00 N m/deg; a range of 10.7 deg is 0.1868 rad
"""

import math

#: Angles and lengths.
rad = 1.0
deg = math.pi / 180.0
m = 1.0
cm = 1e-2
mm = 1e-3
#: Rotational stiffness [N m/rad].
N_m_per_rad = 1.0
N_m_per_deg = 180.0 / math.pi
N_mm_per_deg = 1e-3 * 180.0 / math.pi
N_mm_per_rad = 1e-3
#: Translational stiffness [N/m].
N_per_m = 1.0
N_per_mm = 1e3
N_per_um = 1e6
#: Rotational damping [N m s/rad].
N_m_s_per_rad = 1.0
N_m_s_per_deg = 180.0 / math.pi
#: Translational damping [N s/m].
N_s_per_m = 1.0
N_s_per_mm = 1e3
