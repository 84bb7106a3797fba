"""The paper suite (`iblcheck paper`): one module per experiment, found by its number.

    e01_diffuse_sh              SH9 irradiance by face size, against the reference and brute force
    e02_glossy_lod_bias         the best LOD bias per Phong exponent and face size, McGuire's offset
    e03_fresnel_blends          Fresnel blends: the error against the viewing angle
    e04_frame_time              frame time by effect set and face size
    e05_reference_convergence   the path tracer's noise floor and seconds against spp
    e06_stability               every hard case with what happened (e06_hostile_runs, e06_hostile_cases,
                                e06_hostile_limits: the hostile-input cases and their inputs)
    e07_accuracy_time_ladder    accuracy against time across techniques, plugins included
    e08_occlusion               what shadows and bounces cost (light arrays, shadow maps, PRT)
    e09_parameterizations       cube, dual paraboloid and sphere map at equal texel budgets
    e10_voxel_cone_tracing      what interreflection costs (cascaded voxel cone tracing)

registry.py lists them in number order and describes their common shape; context.py is what each is
handed; suite.py runs them (all, or `--only` a subset) into a report folder.
"""
