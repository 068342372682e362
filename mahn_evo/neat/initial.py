"""Initial populations: the original's seed genomes (``iros2011``) and fully connected minimal genomes.

``iros2011`` (what the paper's runs used, section 8 of the reference sheet):
    genome 0 is an exact copy of ``seedGenome2x_Switch.xml`` (6 CPPN inputs x1, y1, x2, y2, z, S) or
    ``seedGenome2x.xml`` (5 inputs, no S); genomes 1..N-1 are copies with every connection weight (the fixed 1s and
    the 0s included) jittered by U(-0.1, 0.1), unclamped.  The shared innovation counter starts at 610.

``minimal`` (the paper's Algorithm 1, and the usual NEAT start for direct encodings such as XOR):
    the bias and every input connected to every output, no hidden nodes.  Weights are drawn independently per
    genome from U(-initial_weight_range, +initial_weight_range) = U(-1.5, 1.5) by default: that is how SharpNEAT
    1.0's random-genome factory fills weights ((rand - 0.5) * connectionWeightRange, range 3), so a minimal start
    spans the same weight range mutations use.  Connection ids are shared population-wide (matched by endpoints).

The seed XML files give node ids and weights but the order of the 17 (15) connection ids 9-25 (8-22) and the
module gene ids are not part of the sheet; we number the connections in the order listed below and give the two
modules ids 349 and 355 *(inference; neither affects behaviour: the seed is acyclic, so connection order does not
change its activation, and module ids only name modules)*.
"""

from __future__ import annotations

import numpy as np

from .genome import Genome, ModuleGene, NodeGene
from .innovation import InnovationTracker
from .settings import NeatSettings

__all__ = ["initial_population", "iros2011_seed_genome", "minimal_genome", "SEED_NEXT_ID"]

#: First free id after the seed genomes (max seed id 609, + 1).
SEED_NEXT_ID = 610


def iros2011_seed_genome(n_inputs: int = 6) -> Genome:
    """The original seed CPPN: ``seedGenome2x_Switch.xml`` (n_inputs=6) or ``seedGenome2x.xml`` (n_inputs=5).

    Inputs x1, y1, x2, y2, z[, S]; outputs weight and bias (bipolar sigmoid); node 609 = error_sign(z); two Multiply
    modules computing sign(z)*x1 -> 354 and sign(z)*x2 -> 360; weight-0 links into both outputs from the bias, y1,
    y2, [S,] 354 and 360.
    """
    if n_inputs not in (5, 6):
        raise ValueError(f"iros2011 seed genome exists for 5 or 6 CPPN inputs, got n_inputs={n_inputs}")
    x1, y1, x2, y2, z = 1, 2, 3, 4, 5
    out_w, out_b = n_inputs + 1, n_inputs + 2
    nodes = [NodeGene(0, "bias", "null")]
    nodes += [NodeGene(i, "input", "null") for i in range(1, n_inputs + 1)]
    nodes += [NodeGene(out_w, "output", "bipolar_sigmoid"), NodeGene(out_b, "output", "bipolar_sigmoid")]
    nodes += [
        NodeGene(350, "module_in", "identity"),
        NodeGene(352, "module_in", "identity"),
        NodeGene(354, "module_out", "zero"),
        NodeGene(356, "module_in", "identity"),
        NodeGene(358, "module_in", "identity"),
        NodeGene(360, "module_out", "zero"),
        NodeGene(609, "hidden", "error_sign"),
    ]
    modules = [ModuleGene(349, "multiply", (350, 352), (354,)), ModuleGene(355, "multiply", (356, 358), (360,))]
    conns: list[tuple[int, int, float]] = [
        (z, 609, 1.0),
        (609, 350, 1.0),
        (x1, 352, 0.0),
        (609, 356, 1.0),
        (x2, 358, 0.0),
    ]
    into_outputs = [0, y1, y2] + ([6] if n_inputs == 6 else []) + [354, 360]
    for s in into_outputs:
        conns += [(s, out_w, 0.0), (s, out_b, 0.0)]
    first = n_inputs + 3  # 9 for the switch seed, 8 for the signal seed
    innov = np.arange(first, first + len(conns), dtype=np.int64)
    g = Genome(
        nodes,
        innov,
        [c[0] for c in conns],
        [c[1] for c in conns],
        [c[2] for c in conns],
        modules,
    )
    g.validate()
    return g


def minimal_genome(
    n_inputs: int,
    n_outputs: int,
    weights: np.ndarray,
    output_activation: str = "bipolar_sigmoid",
) -> Genome:
    """Bias (id 0), inputs 1..n, outputs n+1..n+m; connection (source-major: bias then inputs, each to every
    output) ids follow from n+m+1."""
    n_src = n_inputs + 1
    nodes = [NodeGene(0, "bias", "null")]
    nodes += [NodeGene(i, "input", "null") for i in range(1, n_inputs + 1)]
    outs = list(range(n_inputs + 1, n_inputs + 1 + n_outputs))
    nodes += [NodeGene(o, "output", output_activation) for o in outs]
    src = np.repeat(np.arange(n_src, dtype=np.int64), n_outputs)
    dst = np.tile(np.asarray(outs, dtype=np.int64), n_src)
    first = n_inputs + 1 + n_outputs
    innov = np.arange(first, first + src.size, dtype=np.int64)
    w = np.asarray(weights, dtype=np.float64)
    if w.shape != src.shape:
        raise ValueError(f"minimal_genome: need {src.size} weights, got shape {w.shape}")
    return Genome(nodes, innov, src, dst, w)


def initial_population(
    kind: str,
    n_inputs: int,
    settings: NeatSettings,
    rng: np.random.Generator,
    n_outputs: int = 2,
    output_activation: str = "bipolar_sigmoid",
) -> tuple[list[Genome], InnovationTracker]:
    """``settings.reproduction.population_size`` genomes and the innovation tracker that continues their ids.

    kind: ``"iros2011"`` (seed genome + jittered copies; n_inputs 5 or 6, two bipolar-sigmoid outputs) or
    ``"minimal"`` (fully connected, no hidden nodes, random weights).
    """
    n = settings.reproduction.population_size
    if n_inputs < 1 or n_outputs < 1:
        raise ValueError(f"initial_population: need n_inputs >= 1 and n_outputs >= 1, got {n_inputs}, {n_outputs}")
    if kind == "iros2011":
        if n_outputs != 2 or output_activation != "bipolar_sigmoid":
            raise ValueError("initial_population: the iros2011 seed has exactly two bipolar_sigmoid outputs")
        seed = iros2011_seed_genome(n_inputs)
        j = settings.initialisation.initial_weight_jitter
        genomes = [seed]
        for _ in range(n - 1):
            genomes.append(seed.with_weights(seed.weight + rng.uniform(-j, j, seed.n_connections)))
        return genomes, InnovationTracker(SEED_NEXT_ID)
    if kind == "minimal":
        r = settings.initialisation.initial_weight_range
        n_conn = (n_inputs + 1) * n_outputs
        first = minimal_genome(n_inputs, n_outputs, rng.uniform(-r, r, n_conn), output_activation)
        genomes = [first] + [first.with_weights(rng.uniform(-r, r, n_conn)) for _ in range(n - 1)]
        return genomes, InnovationTracker(n_inputs + 1 + n_outputs + n_conn)
    raise ValueError(f"initial_population: unknown kind {kind!r} (expected 'iros2011' or 'minimal')")
