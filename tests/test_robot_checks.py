"""wbc.robot_checks.joint_chain against Pinocchio's own ancestry list (model.supports)."""

import pytest

import wbc
from wbc.robot_checks import joint_chain


@pytest.mark.parametrize("name", ["talos", "g1"])
def test_joint_chain_is_pinocchio_supports(name):
    model = wbc.load_robot(name).model
    assert joint_chain(model, 0) == []
    for j in range(1, model.njoints):
        assert joint_chain(model, j) == list(model.supports[j])[1:]
