"""The model stage, the exact model at unit crank speed on plain arrays: slider-crank
kinematics, the loads of each body, lever linkages and their joint forces,
sampling, and the one evaluation every view derives from (:mod:`.evaluate`)."""
