"""Fitting the generic face to a person (Escher, Pandzic, Magnenat-Thalmann, "Facial Deformations for
MPEG-4"): the FDP data path, bpy-free, numpy in and out.

FDP (`fdp_file`, `xface_fdp`) -> completed FP set (`missing_points`, §3.1.1) -> Sibson coordinates of
the generic face, computed once and saved (`sibson`, `dffd`, §3.1) -> fitted rest mesh (`fit`); texture
coordinates from the FPs' UVs (`texture`, §3.2); fitting onto a calibration mesh (`calibration`, §3.3).
The unrolling cylinder, the 2D triangulations, the expanded triangulation and the robust affine fit of
the FPs' motion are `cylinder`, `plane_triangulation`, `expansion` and `affine_fit`. scipy (Qhull) is used
here only, imported by `spatial` when a fit starts, never per frame.
"""
