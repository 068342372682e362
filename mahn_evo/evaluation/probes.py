"""Which part of the paper's test map a team can handle: the team on plus variants that each change one thing.

Why: the test map (`asymmetric_plus`) differs from `plus` in two ways at once.  Its side arms open at different
heights (the right arm leaves the top arm 77.5 cm above the crossing, the left one at the crossing) and its arms
have other lengths (left 48.43 cm, top and right 118.11; plus: 78.74 each).  A team that fails it can fail for
either reason, and the fix differs: a turn rule that waits for both sides of the crossing to open (the team drives
past a side arm that opens alone) needs selection on one-sided openings; a rule that counts distances needs arms
of other lengths.  Each probe plays the sequential (real-world) protocol once, noise-free, on a plus variant that
changes one of these things (`mahn_envs.maps.variants.plus_variant`), so the table says which rule the team
follows.  The raised side arms are shortened by their offset (as `--branch-sides one_short` draws them), so their
posts stay as far from home along the corridors as on plus and only the turn is new.

Measured on the five most general teams of docs/results/experiment_sequential_seeds_1_15/ (noise-free, pymunk):
the ones that fail the test map (seeds 3, 7, 13) drive past every one-sided opening, on either side, and seeds 3
and 7 handle every arm length; the robust one (seed 15) turns at 3 of the 4 one-sided openings and passes the test
map while failing most length probes; seed 12 passes every probe noise-free and fails the test map under noise
(3 of 10), which is robustness to noise, not a rule of the map.  So the turn decides the test map, more than
the lengths do.
"""
from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

from mahn_envs.maps import World, load_map
from mahn_envs.maps.variants import PLUS_ARM, plus_variant

from ..training.champion import Champion
from .eval_champion import champion_policy
from .protocols import sequential_episode

#: the test map's short (left) and long (top, right) arm lengths, cm
TEST_SHORT_ARM = 48.43
TEST_LONG_ARM = 118.11
#: what a probe changes: "turn" (one side arm opens alone, above the crossing), "length" (arm lengths), "map" (a
#: built-in map: plus as the reference, the test map as the sum of both)
PROBE_KINDS = ("map", "turn", "length")


@dataclass(frozen=True)
class Probe:
    """A plus variant (or a built-in map) that changes one thing the test map changes."""

    name: str
    kind: str
    description: str
    builtin: str = ""  # a built-in map's name; else the plus variant's arms (cm) and side-arm offsets (cm)
    left: float = PLUS_ARM
    top: float = PLUS_ARM
    right: float = PLUS_ARM
    left_offset: float = 0.0
    right_offset: float = 0.0

    def __post_init__(self) -> None:
        if self.kind not in PROBE_KINDS:
            raise ValueError(f"probe kind must be one of {PROBE_KINDS}, got {self.kind!r}")

    def world(self) -> World:
        if self.builtin:
            return load_map(self.builtin)
        return plus_variant(self.left, self.top, self.right, self.left_offset, self.right_offset)


def _raised(side: str, offset: float) -> Probe:
    """A turn probe: the `side` arm leaves the top arm `offset` cm above the crossing, shorter by that."""
    left, right = (PLUS_ARM - offset, PLUS_ARM) if side == "left" else (PLUS_ARM, PLUS_ARM - offset)
    return Probe(f"{side}_raised_{offset:g}", "turn", f"the {side} arm leaves the top arm {offset:g} cm above the "
                 "crossing (shorter by that), the other side is at the crossing", left=left, right=right,
                 left_offset=offset if side == "left" else 0.0, right_offset=offset if side == "right" else 0.0)


#: the probes, in the order the table lists them
PROBES: tuple[Probe, ...] = (
    Probe("plus", "map", "the training map", builtin="plus"),
    _raised("left", 30.0), _raised("left", 45.0), _raised("right", 30.0), _raised("right", 45.0),
    Probe("short_left", "length", f"left arm {TEST_SHORT_ARM} cm (the test map's)", left=TEST_SHORT_ARM),
    Probe("short_right", "length", f"right arm {TEST_SHORT_ARM} cm", right=TEST_SHORT_ARM),
    Probe("long_left", "length", f"left arm {TEST_LONG_ARM} cm", left=TEST_LONG_ARM),
    Probe("long_top", "length", f"top arm {TEST_LONG_ARM} cm (the test map's)", top=TEST_LONG_ARM),
    Probe("long_right", "length", f"right arm {TEST_LONG_ARM} cm (the test map's)", right=TEST_LONG_ARM),
    Probe("test_lengths", "length", "the test map's three arm lengths, side arms at the crossing",
          left=TEST_SHORT_ARM, top=TEST_LONG_ARM, right=TEST_LONG_ARM),
    Probe("asymmetric_plus", "map", "the paper's test map: both changes at once", builtin="asymmetric_plus"),
)


def probe_team(champion: Champion, engine: str = "pymunk", names: tuple[str, ...] | None = None
               ) -> list[dict[str, Any]]:
    """One noise-free sequential-protocol episode of the team per probe (all, or those `names`): per probe its
    fields, `stages` (of 3 per robot), `success`, `posts` (robots that reached their own post in the patrol: all
    of them on a turn probe means the team turned there) and, per robot, (post, reached it, came home, went back
    out)."""
    known = {p.name: p for p in PROBES}
    if names is not None:
        unknown = [n for n in names if n not in known]
        if unknown:
            raise ValueError(f"unknown probe(s) {unknown}; known: {list(known)}")
    rows = []
    for probe in PROBES if names is None else tuple(known[n] for n in names):
        result = sequential_episode(champion_policy(champion), probe.world(), champion.task(), seed=0,
                                    engine=engine)
        rows.append({**asdict(probe), "stages": result.stages_completed, "possible": 3 * len(result.robots),
                     "success": result.success, "posts": sum(r.reached_post for r in result.robots),
                     "robots": [[r.post, r.reached_post, r.returned_home, r.went_back_out] for r in result.robots]})
    return rows


def all_posts(row: dict[str, Any]) -> bool:
    """Whether every robot reached its own post in the probe's patrol (on a turn probe: the team turned there)."""
    return row["posts"] == row["possible"] // 3


def probe_summary(rows: list[dict[str, Any]]) -> str:
    """The probe table for people, and what it says: at which one-sided openings the team turns (every robot
    reaches its post) and which arm lengths it handles; and where it also completes the whole protocol."""
    lines = [f"{'probe':<16} {'posts':>5} {'stages':>7}  result   what changes"]
    for r in rows:
        lines.append(f"{r['name']:<16} {r['posts']:>3}/{r['possible'] // 3:<1} {r['stages']:>3}/{r['possible']:<3}  "
                     f"{'success' if r['success'] else 'fail':7}  {r['description']}")
    for side in ("left", "right"):
        turns = [r for r in rows if r["kind"] == "turn" and r["name"].startswith(side)]
        if turns:
            lines.append(f"turns where only the {side} side opens (every post reached): "
                         f"{sum(all_posts(r) for r in turns)} of {len(turns)} probes, whole protocol in "
                         f"{sum(r['success'] for r in turns)}")
    lengths = [r for r in rows if r["kind"] == "length"]
    if lengths:
        lines.append(f"other arm lengths: every post reached in {sum(all_posts(r) for r in lengths)} of "
                     f"{len(lengths)} probes, whole protocol in {sum(r['success'] for r in lengths)}")
    return "\n".join(lines)
