"""Formulations: the one QP per control level, assembled from the shared task and constraint objects, each stated in
its module's docstring: :mod:`wbc.formulations.velocity` (velocity level, v: :class:`VelocityQP`) and
:mod:`wbc.formulations.acceleration` (inverse dynamics, (v̇, f): :class:`InverseDynamicsQP`, compiled tick
:mod:`wbc.formulations.idkernel`)."""
