"""Analyses of a robot's ability, independent of its controller: the legs' step bounds (:mod:`wbc.analysis.legs`)
and the capturability of a push in the linear inverted pendulum (:mod:`wbc.analysis.capturability`)."""
