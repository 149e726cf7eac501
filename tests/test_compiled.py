"""wbc.compiled.specialise: a numba kernel's compiled version called without the dispatcher's type resolution.
Oracles: the dispatcher's own call of the same kernel (bitwise), Pinocchio's integrate, and the types numba gives."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numba as nb
import numpy as np
import pinocchio as pin
import pytest

from wbc.compiled import CHECK_TYPES, specialise
from wbc.configuration import Configuration

ROOT = Path(__file__).resolve().parents[1]


@nb.njit(cache=False)
def _weighted_sum(x, w, out, k):
    s = 0.0
    for i in range(x.shape[0]):
        s += x[i] * w[i]
    out[k] = s
    return s


def test_the_specialised_version_answers_as_the_dispatcher_bit_for_bit():
    rng = np.random.default_rng(3)
    x, w = rng.standard_normal(57), rng.standard_normal(57)
    out_a, out_b = np.zeros(4), np.zeros(4)
    fast = specialise(_weighted_sum, x, w, out_a, 2)
    for _ in range(20):
        x[:], w[:] = rng.standard_normal(57), rng.standard_normal(57)
        a = _weighted_sum(x, w, out_a, 2)
        b = fast(x, w, out_b, 2)
        assert a == b and np.array_equal(out_a, out_b)
    assert _weighted_sum.signatures == [(nb.typeof(x), nb.typeof(w), nb.typeof(out_a), nb.int64)]  # one version


def test_the_tests_check_every_specialised_call_and_a_strided_array_raises():
    assert CHECK_TYPES  # tests/conftest.py sets WBC_CHECK_KERNEL_TYPES=1 before wbc is imported
    x, w, out = np.ones(6), np.ones(6), np.zeros(2)
    fast = specialise(_weighted_sum, x, w, out, 0)
    assert fast(x, w, out, 1) == 6.0 and out[1] == 6.0
    assert fast(x, w, out, 1.0) == 6.0  # a number is converted, as numba's unboxing does: not checked
    with pytest.raises(TypeError, match="specialised for"):
        fast(np.ones(12)[::2], w, out, 0)  # strided: another layout
    with pytest.raises(TypeError, match="specialised for"):
        fast(np.ones((2, 6)), w, out, 0)  # 2-D
    with pytest.raises(TypeError, match="specialised for"):
        fast(x, w, out)  # one argument short


def test_without_the_check_the_specialised_version_is_the_compiled_function_itself():
    code = ("import numba as nb, numpy as np\n"
            "from wbc.compiled import CHECK_TYPES, specialise\n"
            "@nb.njit\n"
            "def k(x):\n"
            "    return x[0]\n"
            "f = specialise(k, np.zeros(3))\n"
            "print(CHECK_TYPES, type(f).__name__, f is k.overloads[k.signatures[0]].entry_point)\n")
    env = {k: v for k, v in os.environ.items() if k != "WBC_CHECK_KERNEL_TYPES"}
    env["PYTHONPATH"] = str(ROOT) + os.pathsep + env.get("PYTHONPATH", "")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=120)
    assert out.stdout.split() == ["False", "builtin_function_or_method", "True"], out.stderr[-2000:]


@pytest.mark.parametrize("layout", ["strided", "read-only"])
def test_a_configuration_keeps_a_contiguous_writeable_q_and_steps_with_any_v(robots, layout):
    """Configuration's specialised kernels take a contiguous writeable q: update() copies a strided or read-only q;
    step() with a strided v (the dispatcher's path) and a contiguous one (the specialised path, after a
    lookahead) both give Pinocchio's integrate."""
    robot = robots("talos")
    model = robot.model
    rng = np.random.default_rng(11)
    q0 = pin.integrate(model, robot.q_ref, 0.05 * rng.standard_normal(model.nv))
    if layout == "strided":
        q_in = np.repeat(q0, 2)[::2]
        assert not q_in.flags.c_contiguous
    else:
        q_in = q0.copy()
        q_in.flags.writeable = False
    config = Configuration(robot)
    config.update(q_in)
    assert config.q.flags.c_contiguous and config.q.flags.writeable and np.array_equal(config.q, q0)
    v = 0.3 * rng.standard_normal(model.nv)
    dt = 0.002
    for v_in, vdt_in in ((np.repeat(v, 2)[::2], np.repeat(v * dt, 2)[::2]), (v.copy(), v * dt)):
        config.update(q0.copy())
        config.lookahead(vdt_in)
        config.step(v_in, dt)
        assert np.array_equal(config.q, pin.integrate(model, q0, v * dt))
