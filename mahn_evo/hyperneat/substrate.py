"""Substrate geometry and CPPN -> team-controller decoding (multiagent HyperNEAT, docs/original-system.md section 6).

Every robot's brain is the same 6(+1)-9-3 substrate painted by one CPPN at the robot's policy-geometry
coordinate z (and, for situational policy geometry, at S = -1 for the patrol brain and S = +1 for the return
brain).  All queries of a whole population are decoded together: the CPPN outputs of every genome are
stacked and thresholded, scaled and normalised with array operations, so decoding costs a few numpy passes
per generation rather than a Python loop per connection.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from numba import njit

from mahn_envs.core.api import policy_coordinates
from mahn_envs.policies.team_controllers import N_INPUTS, TeamControllers

from ..cppn.batch import evaluate_plans

MODES = ("situational", "standard")
#: How the robots' brains relate.  "none": each robot's brains are painted at its own z (the paper).  "mirror":
#: bilateral symmetry by construction: robot r of the first half gets the exact mirror image of the brains painted
#: for robot n-1-r (its partner at -z): inputs, hidden and output nodes reflected left to right (x -> -x), so it
#: acts as its partner would in the mirrored world.  The seed genome's sign(z)*x modules aim at this; evolution
#: breaks it with small z-dependent weights, and most unsolved runs then stall with one side robot returning home
#: and its partner not (docs/results/screen/symmetry/).  Ties between left and right still go left for both (the
#: decision rule is the original's), so a team that decides by such ties is not an exact mirror in behaviour.
#: "best": every team is scored as painted and in both mirror readings (the -z robots mirrored from the +z ones, and
#: the +z robots from the -z ones), and counts as the best of the three (the first on ties, in that order); a
#: plateau team whose one side robot comes home is then also scored with that robot's mirror image in its
#: partner's place (three episodes per team).
SYMMETRIES = ("none", "mirror", "best")
#: the team readings `symmetry="best"` scores, in order: as painted, mirrored from +z, mirrored from -z
READINGS = ("none", "mirror", "mirror_minus")
THRESHOLD = 0.2
WEIGHT_RANGE = 3.0
NORMALISED_SUM = 3.0  # a literal in the original, not WEIGHT_RANGE


def _float32_steps(start: float, step: float, n: int) -> np.ndarray:
    """Positions built by float32 accumulation, as the original laid out its node rows."""
    out = np.empty(n, dtype=np.float32)
    x = np.float32(start)
    for i in range(n):
        out[i] = x
        x = np.float32(x + np.float32(step))
    return out


INPUT_X = _float32_steps(-1.0, 2.0 / 5.0, 6)  # -1, -0.6000000238, ... 1.0
HIDDEN_X = np.linspace(-1.0, 1.0, 9).astype(np.float32)
OUTPUT_X = np.array([-1.0, 0.0, 1.0], dtype=np.float32)  # left, forward, right
SIGNAL_POS = (np.float32(0.0), np.float32(-0.8))


@dataclass(frozen=True)
class QueryLayout:
    """Where each substrate connection and bias lives in the CPPN query matrix of one genome."""

    mode: str
    n_robots: int
    n_brains: int
    queries: np.ndarray  # (Q, n_cppn_inputs) float32
    # index arrays into the query rows, shaped like the controller arrays (R, K, ...)
    q_ih: np.ndarray  # (R, K, 9, 7): -1 where no connection exists (the signal column in situational mode)
    q_hh: np.ndarray  # (R, K, 9, 9)
    q_ho: np.ndarray  # (R, K, 3, 9)
    q_bh: np.ndarray  # (R, K, 9)
    q_bo: np.ndarray  # (R, K, 3)

    @property
    def n_cppn_inputs(self) -> int:
        return self.queries.shape[1]


@lru_cache(maxsize=8)
def query_layout(mode: str, n_robots: int = 3) -> QueryLayout:
    if mode not in MODES:
        raise ValueError(f"mode must be one of {MODES}, got {mode!r}")
    situational = mode == "situational"
    n_brains = 2 if situational else 1
    zs = policy_coordinates(n_robots)
    rows: list[tuple] = []
    R, K, H = n_robots, n_brains, len(HIDDEN_X)
    q_ih = -np.ones((R, K, H, N_INPUTS), dtype=np.int64)
    q_hh = np.zeros((R, K, H, H), dtype=np.int64)
    q_ho = np.zeros((R, K, 3, H), dtype=np.int64)
    q_bh = np.zeros((R, K, H), dtype=np.int64)
    q_bo = np.zeros((R, K, 3), dtype=np.int64)

    def add(x1, y1, x2, y2, z, s) -> int:
        rows.append((x1, y1, x2, y2, z, s) if situational else (x1, y1, x2, y2, z))
        return len(rows) - 1

    for r in range(R):
        z = zs[r]
        for k in range(K):
            s = np.float32(-1.0 if k == 0 else 1.0)
            for i, xh in enumerate(HIDDEN_X):
                q_bh[r, k, i] = add(0.0, 0.0, xh, 0.0, z, s)
            for o, xo in enumerate(OUTPUT_X):
                q_bo[r, k, o] = add(0.0, 0.0, xo, 1.0, z, s)
            for j, xi in enumerate(INPUT_X):
                for i, xh in enumerate(HIDDEN_X):
                    q_ih[r, k, i, j] = add(xi, -1.0, xh, 0.0, z, s)
            if not situational:
                for i, xh in enumerate(HIDDEN_X):
                    q_ih[r, k, i, 6] = add(SIGNAL_POS[0], SIGNAL_POS[1], xh, 0.0, z, s)
            for m, xs in enumerate(HIDDEN_X):
                for i, xh in enumerate(HIDDEN_X):
                    q_hh[r, k, i, m] = add(xs, 0.0, xh, 0.0, z, s)
            for m, xs in enumerate(HIDDEN_X):
                for o, xo in enumerate(OUTPUT_X):
                    q_ho[r, k, o, m] = add(xs, 0.0, xo, 1.0, z, s)
    queries = np.array(rows, dtype=np.float32)
    for a in (queries, q_ih, q_hh, q_ho, q_bh, q_bo):
        a.setflags(write=False)
    return QueryLayout(mode, n_robots, n_brains, queries, q_ih, q_hh, q_ho, q_bh, q_bo)


def _weights_from_outputs(o: np.ndarray) -> np.ndarray:
    """Threshold and scale CPPN weight outputs: |o| <= 0.2 -> no connection, else sign * 3 * (|o|-0.2)/0.8; an output
    that is not a finite number gives no connection (see `_biases_from_outputs`)."""
    o64 = o.astype(np.float64)
    mag = np.abs(o64)
    scaled = np.sign(o64) * WEIGHT_RANGE * (mag - THRESHOLD) / (1.0 - THRESHOLD)
    return np.where((mag > THRESHOLD) & np.isfinite(mag), scaled, 0.0)


def _biases_from_outputs(o: np.ndarray) -> np.ndarray:
    """Scale CPPN bias outputs: 3 * o; an output that is not a finite number (NaN) gives no bias.

    Why: the relaxation activation (`--cppn-activation relax`) can drive a CPPN with recurrent `abs` loops and
    Multiply modules to float32 overflow and then to NaN (inf * 0); seen at generation 343 of situational seed 18
    of the fresh-seed experiment, where it stopped the run.  A NaN weight output already gives no connection (it
    fails the threshold test above), so a NaN bias output gives none either: the CPPN expresses nothing there.
    Finite outputs decode as before, bit for bit."""
    o64 = o.astype(np.float64)
    return np.where(np.isfinite(o64), WEIGHT_RANGE * o64, 0.0)


def _normalise(columns: list[np.ndarray]) -> list[np.ndarray]:
    """Per target node: positive incoming weights sum to +3, negative to -3 (sums in connection order)."""
    pos = np.zeros(columns[0].shape[:-1])
    neg = np.zeros(columns[0].shape[:-1])
    for block in columns:
        for c in range(block.shape[-1]):
            w = block[..., c]
            pos = pos + np.where(w > 0, w, 0.0)
            neg = neg + np.where(w < 0, -w, 0.0)
    pos_scale = np.where(pos > 0, NORMALISED_SUM / np.where(pos > 0, pos, 1.0), 1.0)[..., None]
    neg_scale = np.where(neg > 0, NORMALISED_SUM / np.where(neg > 0, neg, 1.0), 1.0)[..., None]
    return [np.where(b > 0, b * pos_scale, np.where(b < 0, b * neg_scale, 0.0)) for b in columns]


def decode_outputs(outputs: np.ndarray, layout: QueryLayout, normalise: bool = True) -> TeamControllers:
    """CPPN outputs (N, Q, 2) of N genomes -> a batch of N team controllers (arrays (N, R, K, ...)).

    Compiled (`_decode`); `decode_outputs_numpy` is the same rule in array operations, and the tests hold them
    bit-identical.
    """
    if outputs.ndim != 3 or outputs.shape[1:] != (layout.queries.shape[0], 2):
        raise ValueError(f"outputs must have shape (N, {layout.queries.shape[0]}, 2), got {outputs.shape}")
    n = outputs.shape[0]
    R, K, H, n_in = layout.q_ih.shape
    w_ih = np.empty((n, R, K, H, n_in), dtype=np.float32)
    w_hh = np.empty((n, R, K, H, H), dtype=np.float32)
    w_ho = np.empty((n, R, K, 3, H), dtype=np.float32)
    b_h = np.empty((n, R, K, H), dtype=np.float32)
    b_o = np.empty((n, R, K, 3), dtype=np.float32)
    _decode(np.ascontiguousarray(outputs, dtype=np.float32), layout.q_ih, layout.q_hh, layout.q_ho, layout.q_bh,
            layout.q_bo, normalise, w_ih, w_hh, w_ho, b_h, b_o)
    return TeamControllers(w_ih, w_hh, w_ho, b_h, b_o)


@njit(cache=True, error_model="numpy", inline="always")
def _weight(o):
    """`_weights_from_outputs` of one float32 output, in float64 with the same operations."""
    o64 = np.float64(o)
    mag = abs(o64)
    if mag > THRESHOLD and np.isfinite(mag):
        return np.sign(o64) * WEIGHT_RANGE * (mag - THRESHOLD) / (1.0 - THRESHOLD)
    return 0.0


@njit(cache=True, error_model="numpy", inline="always")
def _bias(o):
    """`_biases_from_outputs` of one float32 output."""
    o64 = np.float64(o)
    return np.float32(WEIGHT_RANGE * o64) if np.isfinite(o64) else np.float32(0.0)


@njit(cache=True, error_model="numpy", inline="always")
def _scale(total):
    return NORMALISED_SUM / total if total > 0 else 1.0


@njit(cache=True, error_model="numpy", inline="always")
def _row_scales(row, n, normalise):
    """(positive, negative) scale of one target node's n incoming weights: each sign sums to 3 (sums in order)."""
    if not normalise:
        return 1.0, 1.0
    pos = 0.0
    neg = 0.0
    for c in range(n):
        w = row[c]
        pos = pos + (w if w > 0 else 0.0)
        neg = neg + (-w if w < 0 else 0.0)
    return _scale(pos), _scale(neg)


@njit(cache=True, error_model="numpy", inline="always")
def _scaled(w, pos_scale, neg_scale):
    if w > 0:
        return w * pos_scale
    if w < 0:
        return w * neg_scale
    return 0.0


@njit(cache=True, error_model="numpy")
def _decode(outputs, q_ih, q_hh, q_ho, q_bh, q_bo, normalise, w_ih, w_hh, w_ho, b_h, b_o):
    """`decode_outputs_numpy` per target node: weights, the sums of positive and negative incoming weights in
    connection order (inputs then hidden sources), the scaling, float32 at the end."""
    R, K, H, n_in = q_ih.shape
    row = np.empty(n_in + H)
    for n in range(outputs.shape[0]):
        for r in range(R):
            for k in range(K):
                for i in range(H):
                    for j in range(n_in):
                        q = q_ih[r, k, i, j]
                        row[j] = _weight(outputs[n, q, 0]) if q >= 0 else 0.0
                    for m in range(H):
                        row[n_in + m] = _weight(outputs[n, q_hh[r, k, i, m], 0])
                    pos_scale, neg_scale = _row_scales(row, n_in + H, normalise)
                    for j in range(n_in):
                        w_ih[n, r, k, i, j] = np.float32(_scaled(row[j], pos_scale, neg_scale))
                    for m in range(H):
                        w_hh[n, r, k, i, m] = np.float32(_scaled(row[n_in + m], pos_scale, neg_scale))
                    b_h[n, r, k, i] = _bias(outputs[n, q_bh[r, k, i], 1])
                for o in range(3):
                    for m in range(H):
                        row[m] = _weight(outputs[n, q_ho[r, k, o, m], 0])
                    pos_scale, neg_scale = _row_scales(row, H, normalise)
                    for m in range(H):
                        w_ho[n, r, k, o, m] = np.float32(_scaled(row[m], pos_scale, neg_scale))
                    b_o[n, r, k, o] = _bias(outputs[n, q_bo[r, k, o], 1])


def decode_outputs_numpy(outputs: np.ndarray, layout: QueryLayout, normalise: bool = True) -> TeamControllers:
    """`decode_outputs` in array operations: the reference the compiled version is tested against."""
    if outputs.ndim != 3 or outputs.shape[1:] != (layout.queries.shape[0], 2):
        raise ValueError(f"outputs must have shape (N, {layout.queries.shape[0]}, 2), got {outputs.shape}")
    w_out = outputs[..., 0]
    b_out = outputs[..., 1].astype(np.float64)
    w_ih = _weights_from_outputs(w_out[:, np.maximum(layout.q_ih, 0)])
    w_ih = np.where(layout.q_ih >= 0, w_ih, 0.0)
    w_hh = _weights_from_outputs(w_out[:, layout.q_hh])
    w_ho = _weights_from_outputs(w_out[:, layout.q_ho])
    if normalise:
        w_ih, w_hh = _normalise([w_ih, w_hh])
        (w_ho,) = _normalise([w_ho])
    b_h = _biases_from_outputs(b_out[:, layout.q_bh])
    b_o = _biases_from_outputs(b_out[:, layout.q_bo])
    return TeamControllers(w_ih.astype(np.float32), w_hh.astype(np.float32), w_ho.astype(np.float32),
                           b_h.astype(np.float32), b_o.astype(np.float32))


def mirrored_teams(ctrl: TeamControllers, from_minus: bool = False) -> TeamControllers:
    """The batch with symmetry "mirror": robot r < n-1-r replaced by the mirror image of robot n-1-r (with
    `from_minus`, the other way round: robot n-1-r replaced by the mirror image of robot r).

    Reflection reverses the six sensor inputs (the signal input stays), the hidden nodes and the outputs (left <->
    right): the weight from node a to node b of the copy is the partner's weight from mirror(a) to mirror(b).
    """
    c = ctrl.as_batch()
    w_ih, w_hh, w_ho, b_h, b_o = (np.array(getattr(c, f)) for f in ("w_ih", "w_hh", "w_ho", "b_h", "b_o"))
    n_robots = w_ih.shape[1]
    for low in range(n_robots // 2):
        r, p = (n_robots - 1 - low, low) if from_minus else (low, n_robots - 1 - low)
        w_ih[:, r, :, :, :6] = w_ih[:, p, :, ::-1, 5::-1]
        w_ih[:, r, :, :, 6:] = w_ih[:, p, :, ::-1, 6:]
        w_hh[:, r] = w_hh[:, p, :, ::-1, ::-1]
        w_ho[:, r] = w_ho[:, p, :, ::-1, ::-1]
        b_h[:, r] = b_h[:, p, :, ::-1]
        b_o[:, r] = b_o[:, p, :, ::-1]
    return TeamControllers(w_ih, w_hh, w_ho, b_h, b_o, c.decision)


def team_reading(ctrl: TeamControllers, reading: str) -> TeamControllers:
    """The batch as painted ("none") or in one of its mirror readings ("mirror", "mirror_minus"; READINGS)."""
    if reading not in READINGS:
        raise ValueError(f"reading must be one of {READINGS}, got {reading!r}")
    return ctrl if reading == "none" else mirrored_teams(ctrl, from_minus=reading == "mirror_minus")


def decode_population(plans: Sequence, mode: str, n_robots: int = 3, normalise: bool = True,
                      symmetry: str = "none") -> TeamControllers:
    """Compiled CPPN plans (one per genome) -> a batch of team controllers, one team per genome (with symmetry
    "best", as painted: the evaluator scores its mirror readings)."""
    if symmetry not in SYMMETRIES:
        raise ValueError(f"symmetry must be one of {SYMMETRIES}, got {symmetry!r}")
    layout = query_layout(mode, n_robots)
    teams = decode_outputs(evaluate_plans(plans, layout.queries), layout, normalise)
    return mirrored_teams(teams) if symmetry == "mirror" else teams
