"""mahn_evo: multiagent HyperNEAT (NEAT -> CPPN -> substrate -> team controllers) for the patrol-and-return task."""
