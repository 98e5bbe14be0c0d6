"""Elastic Bones (paper 004, Mujika et al.): a reduced MPEG-4 face skeleton, skinned by Skeleton Subspace
Deformation (eq. 1-2), with an elastic layer on the bones (eq. 3-4); bpy-free, numpy in and out.

The data path, one function each:

    FP positions of a set-up face --skeleton.place_skeleton--> Skeleton (bone heads, tails, parents)
    mesh + Skeleton + opening masks --skinning.skin_weights--> (N, B) weights summing to 1 (eq. 2)
    FAP values --pose.pose_from_faps--> or FP displacements --pose.pose_from_fps--> (B, 4, 4) bone
        transforms relative to rest, the elastic layer (eq. 3-4) included
    rest vertices + weights + transforms --skinning.linear_blend_skinning--> deformed vertices (eq. 1)

`skeleton.BONES` and `rules.RULES` are the tables, `parameters` the gains and elastic weights (UNTRAINED,
and TRAINED by `training` on the development units: `scripts/bench/train_elastic.py`). Bad input raises
`errors.ElasticError` subclasses that name the bone, FP, FAP or vertex. `scripts/bench/elastic_bones.py`
wraps it all for the accuracy benchmark (`evaluate.py --method elastic_bones`).
"""
