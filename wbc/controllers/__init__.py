"""Controllers: each ties a formulation (:mod:`wbc.formulations`) to its solver route and safe command, once per
control tick. Import them from their modules (e.g. :mod:`wbc.controllers.kinematic`)."""
