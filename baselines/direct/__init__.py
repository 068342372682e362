"""Direct-encoding evolution controls (issue 12): the substrate networks HyperNEAT paints, their weights evolved
directly through the same evaluator, by CMA-ES / IPOP-CMA-ES (`cmaes`) and by mahn's NEAT (`neat`).  They separate
"indirect encoding" from "evolution versus gradients"."""
