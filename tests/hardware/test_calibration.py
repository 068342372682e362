"""Calibrations: the paper's formula, the original deployment's, measured tables, custom functions."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mahn_envs.hardware.calibration import (
    LinearCalibration,
    LogCalibration,
    TableCalibration,
    make_calibration,
    relative_noise,
)


def test_paper_formula_values():
    cal = LogCalibration()
    raw = np.array([1, 30, 100, 1000, 1462, 4000])
    expected = np.clip(1.43 - (np.log10(raw) - 0.51) / 2.25, 0, 1)
    np.testing.assert_allclose(cal.to_unit(raw), expected)
    assert cal.to_unit(30) == pytest.approx(1.0, abs=1e-3)  # ~12 cm: the edge of the simulated range
    assert cal.to_unit(1462) == pytest.approx(0.25, abs=1e-3)  # the reflex / floor threshold, ~2.6 cm
    assert cal.to_unit(0) == 1.0  # nothing reflected reads free, not NaN
    assert cal.to_unit(4000) == pytest.approx(1.43 - (math.log10(4000) - 0.51) / 2.25)
    assert np.all((cal.to_unit(np.arange(0, 5000, 7)) >= 0) & (cal.to_unit(np.arange(0, 5000, 7)) <= 1))


@pytest.mark.parametrize("cal", [LogCalibration(), LinearCalibration(),
                                 TableCalibration([20, 60, 420, 1426, 3961], [1.0, 0.75, 0.4, 0.25, 0.0])])
def test_inverse_round_trips_inside_the_range(cal):
    u = np.linspace(0.06, 1.0, 50)
    np.testing.assert_allclose(cal.to_unit(cal.to_raw(u)), u, atol=1e-9)
    # closer (smaller unit) always means more light
    assert np.all(np.diff(cal.to_raw(u)) <= 0)


def test_linear_is_the_original_deployment_transform():
    cal = make_calibration("linear")
    np.testing.assert_allclose(cal.to_unit([0, 1000, 4000, 5000]), [1.0, 0.75, 0.0, 0.0])


def test_table_validation():
    with pytest.raises(ValueError, match="increasing"):
        TableCalibration([10, 5], [1.0, 0.0])
    with pytest.raises(ValueError, match="must not increase"):
        TableCalibration([10, 50], [0.0, 1.0])
    with pytest.raises(ValueError, match="two equally long"):
        TableCalibration([10], [1.0])


def test_make_calibration_accepts_names_objects_and_functions():
    assert make_calibration("paper") is make_calibration("log")
    custom = make_calibration(lambda raw: 2.0 - raw / 100.0)
    np.testing.assert_allclose(custom.to_unit([50, 150, 300]), [1.0, 0.5, 0.0])  # clipped to [0, 1]
    with pytest.raises(NotImplementedError, match="no inverse"):
        custom.to_raw([0.5])
    with pytest.raises(ValueError, match="unknown calibration"):
        make_calibration("banana")
    with pytest.raises(ValueError, match="calibration must be"):
        make_calibration(3)


def test_real_robot_noise_table():
    assert relative_noise(0.0) == pytest.approx(0.0015)
    assert relative_noise(2.25) == pytest.approx(0.22)  # 22.5 mm
    assert relative_noise(100.0) == pytest.approx(1.0)  # clamped at the far end
