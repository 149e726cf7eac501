"""Formulations: the one QP per control level, assembled from the shared task and constraint objects.

* :mod:`wbc.formulations.velocity` — velocity level, decision variable v (:class:`VelocityQP`; its controller is
  :class:`wbc.controllers.kinematic.KinematicController`).
* :mod:`wbc.formulations.acceleration` — acceleration level (inverse dynamics), decision variables (v̇, f)
  (:class:`InverseDynamicsQP`), with its compiled tick :mod:`wbc.formulations.idkernel`.

Each module states its QP once in its docstring (variables, cost, constraints).
"""
