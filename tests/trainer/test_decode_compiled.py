"""The compiled substrate decoding against its array-operation reference: bit-identical controllers."""
import numpy as np
import pytest

from mahn_evo.hyperneat.substrate import THRESHOLD, decode_outputs, decode_outputs_numpy, query_layout
from mahn_evo.hyperneat.team_evaluator import CONTROLLER_FIELDS


@pytest.mark.parametrize("mode", ["situational", "standard"])
@pytest.mark.parametrize("normalise", [True, False])
def test_compiled_decoding_is_bit_identical_to_the_array_reference(mode, normalise):
    layout = query_layout(mode)
    rng = np.random.default_rng(5)
    out = rng.uniform(-1, 1, (40, layout.queries.shape[0], 2)).astype(np.float32)
    out[:, ::7] = np.float32(THRESHOLD)  # exactly at the threshold: no connection
    out[:, 3::11] = -np.float32(THRESHOLD)
    out[:, 1::13] = -0.0
    out[3] = 0.0  # a genome with no connections at all (nothing to normalise)
    out[4, ::5, 0] = np.abs(out[4, ::5, 0])  # mostly positive weights
    out[5, 2::17, 0] = np.nan  # a NaN weight output makes no connection (NaN > threshold is false)
    fast = decode_outputs(out, layout, normalise)
    ref = decode_outputs_numpy(out, layout, normalise)
    for f in CONTROLLER_FIELDS:
        a, b = getattr(fast, f), getattr(ref, f)
        assert a.dtype == b.dtype == np.float32 and a.shape == b.shape
        assert np.array_equal(a.view(np.uint32), b.view(np.uint32)), f
